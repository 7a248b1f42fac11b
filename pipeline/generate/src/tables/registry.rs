//! The tables the pipeline knows how to build, and how to find them.

use super::preset::Preset;
use super::table_def::TableDef;
use super::{epd, epd_albedo, epd_quantile, kcorr, zh, zh_lobe};

pub const TABLES: &[TableDef] = &[
    epd::EPD_G1,
    epd::EPD_NORM,
    epd_quantile::EPD_QUANTILE,
    kcorr::KCORR_RENORM,
    zh::ZH_CONVOLUTION,
    zh_lobe::ZH_LOBE,
    epd_albedo::EPD_ALBEDO,
    epd_albedo::EPD_ALBEDO_AVG,
];

/// The tables a preset has.
pub fn of_preset(preset: Preset) -> impl Iterator<Item = &'static TableDef> {
    TABLES.iter().filter(move |t| t.presets.contains(&preset))
}

pub fn find(name: &str) -> Result<&'static TableDef, String> {
    TABLES.iter().find(|t| t.name == name).ok_or_else(|| {
        let known: Vec<&str> = TABLES.iter().map(|t| t.name).collect();
        format!("unknown table {name:?} (known: {})", known.join(", "))
    })
}
