//! twoscale-tables: the file contract of twoscale's tables and a Rust reader
//! (docs/file_contract.md). It builds nothing: a renderer that only reads
//! tables depends on this crate alone.
//!
//! - `axis`: axes and their encodings (`AxisEncoding`); `interp`: multilinear
//!   interpolation in encoded coordinates;
//! - `derived`: derived axes and value encodings (`ValueEncoding`); `lobe`:
//!   zh_lobe's control variates at a query point;
//! - `manifest`, `checksum`, `file`: the manifest, canonical checksums, and
//!   opening a table (checksums before HDF5); `table`: writing one (HDF5
//!   and manifest, atomically); `verify`: whole folders; `signature`: minisign signatures of bundles and
//!   exports;
//! - `lookup`: physical coordinates in, decoded values out;
//! - `brdf`: a material folder's BRDF with F = 1 (docs/runtimes.md "eval"), also batched over
//!   wavelengths; `vector_math`: ln, exp and cos that vectorize.
//!
//! ```no_run
//! use std::path::Path;
//! use twoscale_tables::Lookup;
//!
//! # fn main() -> anyhow::Result<()> {
//! // Opening verifies the file and every data checksum against the manifest.
//! let g1 = Lookup::open(Path::new("tables-out/default"), "epd_g1")?;
//! let at = [1.5, 0.7]; // p, a: the order of `g1.coordinates()`
//! println!("{:?}", g1.at(&at)?);
//! # Ok(())
//! # }
//! ```

pub mod axis;
pub mod brdf;
pub mod checksum;
pub mod derived;
pub mod file;
pub mod fresnel;
pub mod interp;
pub mod lobe;
pub mod lookup;
pub mod manifest;
pub mod signature;
pub mod spectrum;
pub mod table;
pub mod vector_math;
pub mod verify;

pub use file::open_table;
pub use interp::interpolate;
pub use lookup::Lookup;
