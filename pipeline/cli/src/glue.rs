//! What every command shares: input errors (exit status 2) against failures
//! (1), the one-line error report, logging and the thread pool.

use crate::flags::Common;
use anyhow::Result;
use std::process::ExitCode;
use tracing_subscriber::filter::{LevelFilter, Targets};

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

/// The log filter: RUST_LOG's `target=level` directives and bare levels ("debug",
/// "twoscale_generate=debug,info"), empty ones skipped; unset or blank, `level`. Span and field
/// filters (`target[span]=debug`, EnvFilter's) are not read: RUST_LOG is then ignored, and the
/// second value says so in one line, as it does for a directive that does not parse.
fn log_filter(rust_log: Option<&str>, level: LevelFilter) -> (Targets, Option<String>) {
    let default = || Targets::new().with_default(level);
    let Some(text) = rust_log else { return (default(), None) };
    let directives: Vec<&str> = text.split(',').map(str::trim).filter(|d| !d.is_empty()).collect();
    if directives.is_empty() {
        return (default(), None);
    }
    let ignored = |why: &str| (default(), Some(format!("RUST_LOG={text:?} ignored: {why}")));
    if directives.iter().any(|d| d.contains(['[', '{'])) {
        return ignored("span and field filters are not supported, only target=level directives");
    }
    match directives.join(",").parse::<Targets>() {
        Ok(targets) => (targets, None),
        Err(e) => ignored(&e.to_string()),
    }
}

pub fn init(common: &Common) {
    use tracing_subscriber::prelude::*;
    let level = if common.quiet { LevelFilter::WARN } else { LevelFilter::INFO };
    let (filter, warning) = log_filter(std::env::var("RUST_LOG").ok().as_deref(), level);
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use tracing::Level;

    /// Whether `filter` lets an event of `level` from `target` through.
    fn shows(filter: &Targets, target: &str, level: Level) -> bool {
        filter.would_enable(target, &level)
    }

    #[test]
    fn rust_log_directives_and_their_fallbacks() {
        let info = LevelFilter::INFO;
        // unset, empty or only commas: the command's level
        for text in [None, Some(""), Some(" , ")] {
            let (f, warning) = log_filter(text, info);
            assert!(shows(&f, "twoscale_generate::build", Level::INFO) && !shows(&f, "x", Level::DEBUG), "{text:?}");
            assert!(warning.is_none(), "{text:?}");
        }
        // a bare level, a trailing comma, target=level beside a default
        let (f, _) = log_filter(Some("debug,"), info);
        assert!(shows(&f, "x", Level::DEBUG) && !shows(&f, "x", Level::TRACE));
        let (f, _) = log_filter(Some("twoscale_generate=debug,warn"), info);
        assert!(shows(&f, "twoscale_generate::build", Level::DEBUG) && !shows(&f, "twoscale_cli", Level::INFO));
        assert!(shows(&f, "twoscale_cli", Level::WARN));
        // span filters and unparsable levels: RUST_LOG ignored, said in one line
        for text in ["twoscale_generate[build]=debug", "x=loud"] {
            let (f, warning) = log_filter(Some(text), info);
            assert!(shows(&f, "x", Level::INFO) && !shows(&f, "x", Level::DEBUG), "{text}");
            let w = warning.unwrap_or_default();
            assert!(w.starts_with("RUST_LOG=") && w.contains("ignored") && !w.contains('\n'), "{text}: {w}");
        }
    }
}
