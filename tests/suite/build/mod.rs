//! Building tables: the presets, zh_lobe end to end, and the release rules of data changes.

mod presets;
mod release;
mod zh_lobe;
