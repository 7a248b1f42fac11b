//! Helpers shared by the integration tests. Every `tests/*.rs` is a test of
//! the root package `twoscale-cli`, found by Cargo without any registration:
//! a new file there runs with `cargo test` (and `make test`). It starts with
//! `mod common;` to use these helpers; this folder (`tests/common/`) is not a
//! test of its own.
#![allow(dead_code)] // each test file uses some of these

use std::path::{Path, PathBuf};

/// The `twoscale` binary of this build.
pub const BIN: &str = env!("CARGO_BIN_EXE_twoscale");

/// The repository's root (the root package's folder).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// Double-exponential quadrature (the `quadrature` crate, independent of the
/// project's Gauss-Kronrod code) over [lo, hi], split into pieces that start
/// at width `first` and grow by `growth`, so that mass near `lo` on a long
/// interval is not missed (that crate stops at ~385 evaluations per call).
pub fn de_split(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, first: f64, growth: f64) -> f64 {
    let (mut a, mut step, mut sum) = (lo, first, 0.0);
    while a < hi {
        let b = (a + step).min(hi);
        sum += quadrature::double_exponential::integrate(f, a, b, 1e-15).integral;
        a = b;
        step *= growth;
    }
    sum
}
