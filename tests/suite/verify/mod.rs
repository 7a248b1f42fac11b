//! Verifying tables: corrupt files and manifests (fuzzed), `twoscale verify` and bundles.

mod files;
mod fuzz;
