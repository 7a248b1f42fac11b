//! A table in memory, its HDF5 file (SPEC section 6) and canonical checksums.

use crate::derived::Encoding as ValueCoding;
use crate::grid::Axis;
use crate::manifest::{axis_entry, Contract, Manifest};
use anyhow::{anyhow, bail, Context, Result};
use hdf5::types::VarLenUnicode;
use ndarray::{ArrayD, IxDyn};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::str::FromStr;

pub const FORMAT: &str = "twoscale-table/1";

#[derive(Clone, Debug)]
pub struct Table {
    pub name: String,
    pub preset: String,
    pub axes: Vec<Axis>,
    /// (value name, data with shape = axis lengths).
    pub values: Vec<(String, ArrayD<f32>)>,
}

impl Table {
    pub fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(Axis::len).collect()
    }

    pub fn value(&self, name: &str) -> Option<&ArrayD<f32>> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
}

/// `<table>.manifest.json` in `dir`.
pub fn manifest_path(dir: &Path, table: &str) -> PathBuf {
    dir.join(format!("{table}.manifest.json"))
}

/// `<table>.h5` in `dir`.
pub fn h5_path(dir: &Path, table: &str) -> PathBuf {
    dir.join(format!("{table}.h5"))
}

/// SHA-256 of a stream of little-endian numbers, hashed 64 KiB at a time
/// (one `update` per number costs more than the hash itself).
fn sha256_le<const N: usize>(data: impl Iterator<Item = [u8; N]>) -> String {
    const BLOCK: usize = 1 << 16;
    let mut h = Sha256::new();
    let mut buf = Vec::with_capacity(BLOCK + N);
    for bytes in data {
        buf.extend_from_slice(&bytes);
        if buf.len() >= BLOCK {
            h.update(&buf);
            buf.clear();
        }
    }
    h.update(&buf);
    hex(&h.finalize())
}

/// SHA-256 of little-endian f64 in the given order.
pub fn sha256_f64(data: &[f64]) -> String {
    sha256_le(data.iter().map(|x| x.to_le_bytes()))
}

/// SHA-256 of little-endian f32 in the given order (an array's: C order).
pub fn sha256_f32<'a>(data: impl IntoIterator<Item = &'a f32>) -> String {
    sha256_le(data.into_iter().map(|x| x.to_le_bytes()))
}

pub fn sha256_bytes(data: &[u8]) -> String {
    hex(&Sha256::digest(data))
}

/// SHA-256 of a file's bytes, read 1 MiB at a time.
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut file = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut h = Sha256::new();
    std::io::copy(&mut file, &mut h).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(hex(&h.finalize()))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Writes `bytes` to `path` through a temporary file in the same directory
/// and a rename, so that `path` is either absent, the old file or complete.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to `path` atomically (see `write_atomic`).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |tmp| Ok(std::fs::write(tmp, bytes)?))
}

/// A hidden name beside `path` that keeps its extension (writers that pick
/// the format from it, like the PNG encoder, still see it).
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".tmp-{}-{name}", std::process::id()))
}

fn str_attr(loc: &hdf5::Location, name: &str, value: &str) -> Result<()> {
    let v = VarLenUnicode::from_str(value).map_err(|e| anyhow::anyhow!("attribute {name}: {e}"))?;
    loc.new_attr::<VarLenUnicode>().create(name)?.write_scalar(&v)?;
    Ok(())
}

fn read_str_attr(loc: &hdf5::Location, name: &str) -> Result<String> {
    let v: VarLenUnicode = loc.attr(name)?.read_scalar()?;
    Ok(v.as_str().to_string())
}

/// Writes the table's HDF5 file (atomically). No timestamps are recorded, so
/// the bytes depend only on the data. The root attribute `contract` holds
/// what a lookup reads from the manifest besides checksums (`Contract`), so
/// that a reader can hold the manifest to the verified file.
pub fn write_h5(table: &Table, contract: &Contract, generator_version: &str, path: &Path) -> Result<()> {
    write_atomic(path, |tmp| {
        let file = hdf5::File::with_options()
            .with_fcpl(|p| p.obj_track_times(false))
            .create(tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        str_attr(&file, "format", FORMAT)?;
        str_attr(&file, "table", &table.name)?;
        str_attr(&file, "preset", &table.preset)?;
        str_attr(&file, "generator_version", generator_version)?;
        str_attr(&file, "contract", &serde_json::to_string(contract)?)?;
        let axes = file.create_group_builder().obj_track_times(false).create("axes")?;
        for axis in &table.axes {
            let ds = axes.new_dataset_builder().with_data(&axis.nodes).create(axis.name.as_str())?;
            str_attr(&ds, "encoding", &axis.encoding.formula())?;
        }
        let values = file.create_group_builder().obj_track_times(false).create("values")?;
        for (name, data) in &table.values {
            values.new_dataset_builder().with_data(data.view()).create(name.as_str())?;
        }
        file.close()?;
        Ok(())
    })
}

/// The data of a table file: root attributes, axes (nodes only) and values.
pub struct H5Contents {
    pub table: String,
    pub preset: String,
    pub contract: Contract,
    pub axes: Vec<(String, Vec<f64>)>,
    pub values: Vec<(String, ArrayD<f32>)>,
}

/// Reads a table file written by `write_h5`, with the axis and value names
/// expected (in order). Any structural problem is an error naming the file.
/// Only for a file whose bytes were verified (`verify_file`): the HDF5
/// library can crash or hang on a malformed one.
fn read_h5(path: &Path, axis_names: &[&str], value_names: &[&str]) -> Result<H5Contents> {
    let ctx = || format!("{}: not a readable twoscale table", path.display());
    let inner = || -> Result<H5Contents> {
        let file = hdf5::File::open(path)?;
        let format = read_str_attr(&file, "format")?;
        if format != FORMAT {
            bail!("format is {format:?}, expected {FORMAT:?}");
        }
        if !file.attr_names()?.iter().any(|n| n == "contract") {
            bail!("no attribute `contract` (written before twoscale 0.8.0): rebuild it");
        }
        let contract = serde_json::from_str(&read_str_attr(&file, "contract")?).context("attribute contract")?;
        let axes = axis_names
            .iter()
            .map(|&n| Ok((n.to_string(), file.dataset(&format!("axes/{n}"))?.read_raw::<f64>()?)))
            .collect::<Result<Vec<_>>>()?;
        let shape: Vec<usize> = axes.iter().map(|(_, v)| v.len()).collect();
        let values = value_names
            .iter()
            .map(|&n| {
                let ds = file.dataset(&format!("values/{n}"))?;
                if ds.shape() != shape {
                    bail!("values/{n} has shape {:?}, axes give {:?}", ds.shape(), shape);
                }
                let raw = ds.read_raw::<f32>()?;
                Ok((n.to_string(), ArrayD::from_shape_vec(IxDyn(&shape), raw)?))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(H5Contents {
            table: read_str_attr(&file, "table")?,
            preset: read_str_attr(&file, "preset")?,
            contract,
            axes,
            values,
        })
    };
    inner().with_context(ctx)
}

/// The value encodings `ln_control_variates`, `ln_control_variates_tails` and `ln_control_variates_epd`
/// read the coordinates u, c, p, beta and theta_h, the last one derived
/// (zh_lobe's layout): every reader relies on it.
fn check_control_variates(manifest: &Manifest) -> Result<()> {
    let Some(kind) = manifest.value_encoding.iter().map(|e| e.encoding).find(|e| *e != ValueCoding::Ln).map(ValueCoding::kind) else {
        return Ok(());
    };
    let lobe = ["u", "c", "p", "beta", "theta_h"];
    let derived = |axis: &str| manifest.derived_axes.iter().find(|d| d.axis == axis);
    let names: Vec<&str> = manifest.axes.iter().map(|a| derived(&a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str())).collect();
    let last_derived = manifest.derived_axes.len() == 1
        && names.len() == lobe.len()
        && derived(&manifest.axes[4].name).is_some_and(|d| matches!(d.derivation, crate::derived::Derivation::AnchoredLobeAngle { .. }));
    if names != lobe || !last_derived {
        bail!("value encoding {kind} needs the coordinates {} (theta_h derived), not {}", lobe.join(", "), names.join(", "));
    }
    Ok(())
}

/// The manifest of `table` in `dir`: `<table>.manifest.json`, well-formed and naming `table`.
pub fn read_manifest(dir: &Path, table: &str) -> Result<Manifest> {
    let mpath = manifest_path(dir, table);
    let text = std::fs::read_to_string(&mpath).with_context(|| format!("cannot read {}", mpath.display()))?;
    let manifest: Manifest =
        serde_json::from_str(&text).with_context(|| format!("{}: malformed manifest", mpath.display()))?;
    if manifest.format != crate::manifest::FORMAT {
        bail!("{}: malformed manifest: format {:?}, not {:?}", mpath.display(), manifest.format, crate::manifest::FORMAT);
    }
    if manifest.table != table {
        bail!("{}: malformed manifest: it is for table {:?}, not {table:?}", mpath.display(), manifest.table);
    }
    Ok(manifest)
}

/// Checks the table file named by `manifest` in `dir` (its name must be
/// `<table>.h5`, a plain name) against the manifest's size and SHA-256, and
/// returns its path. Every reader calls this before HDF5 sees the file: the
/// HDF5 library can crash or hang on a malformed one.
pub fn verify_file(dir: &Path, manifest: &Manifest) -> Result<PathBuf> {
    let expected = format!("{}.h5", manifest.table);
    if manifest.file.path != expected {
        bail!("{}: malformed manifest: file.path is {:?}, not {expected:?}", manifest_path(dir, &manifest.table).display(), manifest.file.path);
    }
    let path = dir.join(&expected);
    let meta = std::fs::metadata(&path).with_context(|| format!("cannot read {}", path.display()))?;
    if !meta.is_file() {
        bail!("{} is not a file", path.display());
    }
    if meta.len() != manifest.file.bytes {
        bail!("{} has {} bytes, the manifest says {}", path.display(), meta.len(), manifest.file.bytes);
    }
    if sha256_file(&path)? != manifest.file.sha256 {
        bail!("{}: file checksum differs from the manifest", path.display());
    }
    Ok(path)
}

/// A table as read: its manifest, axes (with encodings) and named values.
pub type TableData = (Manifest, Vec<Axis>, Vec<(String, ArrayD<f32>)>);

/// Reads a table and its manifest from `dir`: the file is verified against
/// the manifest (`verify_file`) before it is opened, then every data
/// checksum, and the manifest must describe the file exactly (`Contract`,
/// axis and value entries). Returns the axes (with their encodings) and values.
pub fn open_table(dir: &Path, table: &str) -> Result<TableData> {
    let manifest = read_manifest(dir, table)?;
    let mpath = manifest_path(dir, table);
    let h5 = verify_file(dir, &manifest)?;
    let axis_names: Vec<&str> = manifest.axes.iter().map(|a| a.name.as_str()).collect();
    let value_names: Vec<&str> = manifest.values.iter().map(|v| v.name.as_str()).collect();
    let contents = read_h5(&h5, &axis_names, &value_names)?;
    let disagree = |what: &str| anyhow!("{}: {what} differs from the file {}", mpath.display(), h5.display());
    if (contents.table.as_str(), contents.preset.as_str()) != (manifest.table.as_str(), manifest.preset.as_str()) {
        return Err(disagree("the table or preset"));
    }
    if contents.contract != Contract::of_manifest(&manifest) {
        return Err(disagree("the contract (axis order and encodings, derived axes, value encodings)"));
    }
    let mut axes = Vec::new();
    for ((name, nodes), entry) in contents.axes.into_iter().zip(&manifest.axes) {
        if sha256_f64(&nodes) != entry.sha256 {
            bail!("{}: axis {name} does not match the checksum in {}", h5.display(), mpath.display());
        }
        let axis = Axis::new(&name, nodes, entry.encoding);
        if axis_entry(&axis) != *entry {
            return Err(disagree(&format!("axis {name}'s entry (size, range, encoding, uniform)")));
        }
        axes.push(axis);
    }
    for ((name, data), entry) in contents.values.iter().zip(&manifest.values) {
        if sha256_f32(data) != entry.sha256 {
            bail!("{}: values/{name} does not match the checksum in {}", h5.display(), mpath.display());
        }
        if entry.dtype != "float32" || entry.shape != data.shape() {
            return Err(disagree(&format!("values/{name}'s entry (dtype, shape)")));
        }
    }
    check_control_variates(&manifest).with_context(|| format!("{}: malformed manifest", mpath.display()))?;
    Ok((manifest, axes, contents.values))
}
