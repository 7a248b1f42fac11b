//! Scenes: scene files and their sub-domains, per-material tables, the albedo tables.

mod albedo;
mod materials;
mod scene_files;
