//! Building tables: the presets, zh_lobe end to end, and the release rules of data changes. (Not
//! named `build`: global gitignores skip folders of that name.)

mod builds;
mod release;
mod zh_lobe;
