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
