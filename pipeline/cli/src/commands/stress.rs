//! `twoscale stress`.

use crate::flags::StressArgs;
use anyhow::{bail, Result};

pub fn run_stress(args: &StressArgs) -> Result<()> {
    let report = twoscale_quality::stress::run(args.quick);
    if args.json {
        println!("{report}");
    } else {
        println!("{} cases, {} failures", report["cases"], report["failures"]);
        for f in report["failed"].as_array().into_iter().flatten() {
            println!("  {} at {}: {}", f["check"].as_str().unwrap_or(""), f["at"], f["detail"].as_str().unwrap_or(""));
        }
    }
    if report["failures"] != 0 {
        bail!("{} stress cases failed", report["failures"]);
    }
    Ok(())
}
