//! Verifying tables: corrupt files and manifests (fuzzed), `twoscale verify`, bundles and their signatures.

mod files;
mod fuzz;
mod signature;
