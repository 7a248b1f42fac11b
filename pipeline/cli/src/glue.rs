//! What every command shares: input errors (exit status 2) against failures
//! (1), the one-line error report, logging and the thread pool.

use crate::flags::Common;
use anyhow::Result;
use std::process::ExitCode;

/// An error that is the user's input (exit status 2) rather than a failure (1).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

pub(crate) fn input_error(msg: impl Into<String>) -> anyhow::Error {
    InputError(msg.into()).into()
}

pub fn init(common: &Common) {
    use tracing_subscriber::filter::{LevelFilter, Targets};
    use tracing_subscriber::prelude::*;
    let level = if common.quiet { LevelFilter::WARN } else { LevelFilter::INFO };
    // RUST_LOG overrides the level: "debug", or "twoscale_generate=debug,info" (target=level directives).
    let filter = std::env::var("RUST_LOG")
        .ok()
        .and_then(|s| s.parse::<Targets>().ok())
        .unwrap_or_else(|| Targets::new().with_default(level));
    let fmt = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false);
    let _ = tracing_subscriber::registry().with(fmt).with(filter).try_init();
    if let Some(n) = common.threads {
        let _ = rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global();
    }
}

/// Prints the error on one line and maps it to the exit status.
pub fn report(program: &str, result: Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let line = format!("{e:#}").replace('\n', " ");
            eprintln!("{program}: error: {line}");
            if e.downcast_ref::<InputError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

/// A table name as a file stem: a plain name of letters, digits and _.
pub(crate) fn table_name(name: &str) -> Result<&str> {
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_') {
        return Err(input_error(format!("{name:?} is not a table name (lowercase letters, digits and _)")));
    }
    Ok(name)
}
