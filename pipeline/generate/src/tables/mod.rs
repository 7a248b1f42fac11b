//! The tables: one module per table with its maths beside it (`epd`, `kcorr`, `zh`, `zh_lobe`,
//! `epd_albedo`, ...), and the concepts every table shares: presets (`preset`), a build as a job
//! of independent units (`job`), the options that change how a table is computed (`options`), a
//! scene's target and sub-domain (`scene_target`, `sub_domain`), what a table is (`table_def`)
//! and the registry the CLI builds from (`registry`). The table modules import these concept
//! modules directly; the re-exports below are for the other modules and crates.

pub mod context;
pub mod epd;
pub mod epd_albedo;
pub mod epd_albedo_column;
pub mod epd_albedo_math;
pub mod epd_math;
pub mod epd_quantile;
pub mod job;
pub mod kcorr;
pub mod kcorr_math;
pub mod lambda_table;
pub mod nodewise;
pub mod options;
pub mod preset;
pub mod registry;
pub mod scene_target;
pub mod sub_domain;
pub mod table_def;
pub mod zh;
mod zh_budget;
pub mod zh_fit;
pub mod zh_grid;
pub mod zh_lobe;
pub mod zh_math;

pub use job::{Built, Job, Part, Units};
pub use options::{BuildOptions, Method};
pub use preset::Preset;
pub use registry::{find, of_preset, TABLES};
pub use scene_target::{Range, SceneTarget};
pub use sub_domain::{restrict, sub_domain};
pub use table_def::TableDef;
