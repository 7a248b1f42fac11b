//! Shipping: everything that carries built tables to other runtimes and users,
//! and builds no table itself.
//!
//! - `export`: `.npy` arrays and C headers;
//! - `webgl` and `webgl_general`: the WebGL runtime's files (per material and general);
//! - `bundle`: `.tar.gz` bundles with their checksums;
//! - `signing`: Ed25519 keys and minisign-format signatures of bundles.
//!
//! Import direction: `ship` reads what the builders wrote (through `twoscale_tables`)
//! and uses `build`'s generator identity; no table builder imports `ship`.

pub mod bundle;
pub mod export;
pub mod signing;
pub mod webgl;
pub mod webgl_general;
