//! Parsers of option values: a preset, a preset directory, a shard, a method.

use twoscale_generate::shard::ShardSpec;
use twoscale_generate::tables::{Method, Preset};

pub(super) fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse()
}

/// A preset name, or the `scene-<name>` directory of a scene build.
pub(super) fn parse_target(s: &str) -> Result<String, String> {
    if s.strip_prefix("scene-").is_some_and(|n| !n.is_empty() && !n.contains(['/', '\\'])) {
        return Ok(s.to_string());
    }
    parse_preset(s).map(|p| p.name().to_string()).map_err(|e| format!("{e}, or scene-<name>"))
}

pub(super) fn parse_shard(s: &str) -> Result<ShardSpec, String> {
    s.parse()
}

pub(super) fn parse_method(s: &str) -> Result<Method, String> {
    s.parse()
}

/// Three wavelengths in micrometres: red, green, blue.
#[derive(Clone, Copy, Debug)]
pub struct Wavelengths(pub [f64; 3]);

pub(super) fn parse_wavelengths(s: &str) -> Result<Wavelengths, String> {
    let v: Vec<f64> =
        s.split(',').map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [r, g, b] if !v.iter().all(|x| x.is_finite() && (0.2..=2.0).contains(x)) => {
            Err(format!("wavelengths are micrometres in [0.2, 2], got {r}, {g}, {b}"))
        }
        [r, g, b] if r == g || g == b || r == b => {
            Err("three different wavelengths (a scene's spectra need them)".into())
        }
        [r, g, b] => Ok(Wavelengths([r, g, b])),
        _ => Err(format!("three wavelengths (red, green, blue), got {}", v.len())),
    }
}

/// A sample count, or every sample.
#[derive(Clone, Copy, Debug)]
pub struct SampleCount(pub Option<usize>);

pub(super) fn parse_sample_count(s: &str) -> Result<SampleCount, String> {
    if s == "all" {
        return Ok(SampleCount(None));
    }
    match s.parse::<usize>() {
        Ok(n) if n >= 1000 => Ok(SampleCount(Some(n))),
        Ok(_) => Err("at least 1000 samples, or all".into()),
        Err(e) => Err(format!("{e}")),
    }
}
