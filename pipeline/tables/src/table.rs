//! A table in memory and how its HDF5 file and manifest are written (docs/file_contract.md),
//! atomically: the writing half of the contract, beside its reading half (`file`).

use crate::axis::Axis;
use crate::checksum::sha256_f32;
use crate::derived::Derived;
use crate::file::FORMAT;
use crate::manifest::{Contract, ContractAxis, ValueEntry};
use anyhow::{Context, Result};
use hdf5::types::VarLenUnicode;
use ndarray::ArrayD;
use std::path::{Path, PathBuf};
use std::str::FromStr;

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

    /// What its file's `contract` attribute and its manifest state (see `Contract`).
    pub fn contract(&self, derived: &Derived) -> Contract {
        Contract {
            axes: self.axes.iter().map(|a| ContractAxis { name: a.name.clone(), encoding: a.encoding }).collect(),
            values: self.values.iter().map(|(n, _)| n.clone()).collect(),
            derived_axes: derived.axes.clone(),
            value_encoding: derived.values.clone(),
            interpolation: derived.interpolation,
        }
    }

    /// The manifest's value entries: name, dtype, shape and data checksum.
    pub fn value_entries(&self) -> Vec<ValueEntry> {
        self.values
            .iter()
            .map(|(name, data)| ValueEntry {
                name: name.clone(),
                dtype: "float32".into(),
                shape: data.shape().to_vec(),
                sha256: sha256_f32(data),
            })
            .collect()
    }
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

/// `value` as pretty JSON with a final newline, written atomically: the one form of every manifest
/// (tables', shards') and bundle description.
pub fn write_json_atomic(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    write_bytes_atomic(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}

/// A hidden name beside `path` that keeps its extension (writers that pick
/// the format from it, like the PNG encoder, still see it).
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".tmp-{}-{name}", std::process::id()))
}

/// Writes the string attribute `name` (HDF5 variable-length UTF-8), as every file of the contract
/// (tables, shards) holds its attributes.
pub fn str_attr(loc: &hdf5::Location, name: &str, value: &str) -> Result<()> {
    let v = VarLenUnicode::from_str(value).map_err(|e| anyhow::anyhow!("attribute {name}: {e}"))?;
    loc.new_attr::<VarLenUnicode>().create(name)?.write_scalar(&v)?;
    Ok(())
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
