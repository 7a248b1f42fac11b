//! A measured BRDF as the fit takes it, whatever its file: the samples (a direction pair and rho per
//! channel each), the lobe nodes they share, and the file itself, which evaluates its own
//! interpolation at any direction pair (what a renderer of the file sees: `render`).
//!
//! A sample's lobe node is a (theta_h, cos theta_d) pair: the diffraction lobe C depends on a sample
//! only through them, so it is looked up once per node and channel (`GeneralTables::parts`). A MERL
//! file's samples share its (theta_h, theta_d) bin pairs; an RGL file's each have their own.

use crate::merl::{self, Merl};
use crate::model::lobe_node;
use crate::rgl::{self, Rgl};
pub use crate::sample::Sample;
use anyhow::{bail, Context, Result};
use std::path::Path;

/// A measured file's valid samples, their lobe nodes, and the file.
pub struct Measured {
    pub samples: Vec<Sample>,
    /// (theta_h, cos theta_d) of each lobe node.
    pub nodes: Vec<(f64, f64)>,
    /// Samples left out, with the reason (below the horizon, grazing, marked invalid).
    pub skipped: Vec<(&'static str, usize)>,
    pub file: File,
}

/// The file a `Measured` was read from, kept to evaluate it between its samples.
pub enum File {
    Merl(Box<Merl>),
    Rgl(Box<Rgl>),
}

impl File {
    /// What kind of file, for messages and the JSON.
    pub fn format(&self) -> &'static str {
        match self {
            File::Merl(_) => "MERL",
            File::Rgl(_) => "RGL",
        }
    }

    /// rho per channel at (wi, wo) as the file's own reader interpolates it (MERL: trilinear in its bin
    /// coordinates; RGL: Mitsuba's `measured` plugin's interpolation, wi its si.wi, the file's incident
    /// direction), 0 below the horizon.
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        match self {
            File::Merl(m) => m.rho(wi, wo),
            File::Rgl(r) => r.rho(wi, wo),
        }
    }
}

/// The RGL `tensor_file`'s magic: any other file is read as MERL.
const TENSOR_MAGIC: &[u8] = b"tensor_file\0";

/// Reads a measured file, RGL (`tensor_file`, *.bsdf) or MERL (.binary), by its first bytes; every
/// error names the file.
pub fn read(path: &Path) -> Result<Measured> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let named_rgl = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bsdf"));
    if named_rgl && !bytes.starts_with(TENSOR_MAGIC) {
        bail!("{}: not an RGL file (a .bsdf file starts with the 12 bytes \"tensor_file\\0\")", path.display());
    }
    parse(&bytes).with_context(|| format!("{}", path.display()))
}

/// `read` on the file's bytes.
pub fn parse(bytes: &[u8]) -> Result<Measured> {
    if bytes.starts_with(TENSOR_MAGIC) {
        rgl::parse(bytes).and_then(of_rgl)
    } else {
        let (merl, samples, skipped) = merl::parse(bytes)?;
        Ok(Measured { samples, nodes: merl::lobe_nodes(), skipped, file: File::Merl(Box::new(merl)) })
    }
}

/// How many samples, and those left out, in one line.
pub fn describe(m: &Measured) -> String {
    let skipped: Vec<String> = m.skipped.iter().map(|(why, n)| format!("{n} {why}")).collect();
    let about = match &m.file {
        // the file's own description's first line, shortened: it can run to paragraphs
        File::Rgl(r) if !r.description.trim().is_empty() => {
            format!(" \"{}\"", r.description.trim().lines().next().unwrap_or("").chars().take(80).collect::<String>())
        }
        _ => String::new(),
    };
    format!("{} file{about}: {} valid samples ({})", m.file.format(), m.samples.len(), skipped.join(", "))
}

/// An RGL file's measured nodes as samples, each its own lobe node, keyed by its grid index.
fn of_rgl(file: Rgl) -> Result<Measured> {
    let nodes_in_file = file.theta_i.len() * file.n * file.n;
    let measured = file.samples();
    let samples: Vec<Sample> = measured
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let [k, y, x] = s.index;
            let key = ((k * file.n + y) * file.n + x) as u64;
            Sample { wi: s.wi, wo: s.wo, rho: s.rho, node: i as u32, key, measure: s.measure }
        })
        .collect();
    let nodes = measured.iter().map(|s| lobe_node(s.wi, s.wo)).collect();
    if samples.is_empty() {
        bail!("no valid sample: every node is marked invalid or has a direction below the horizon");
    }
    let skipped = vec![("invalid or below the horizon", nodes_in_file - samples.len())];
    Ok(Measured { samples, nodes, skipped, file: File::Rgl(Box::new(file)) })
}
