//! Opening a table as the file contract requires (docs/file_contract.md):
//! the manifest first, then the file's size and SHA-256, and only then HDF5
//! (which can crash or hang on a malformed file), then every data checksum
//! and the manifest against the file's `contract` attribute.

use crate::axis::Axis;
use crate::checksum::{sha256_f32, sha256_f64, sha256_file};
use crate::interp::Interpolation;
use crate::lobe::Term;
use crate::manifest::{axis_entry, Contract, Manifest};
use anyhow::{anyhow, bail, Context, Result};
use hdf5::types::VarLenUnicode;
use ndarray::{ArrayD, IxDyn};
use std::path::{Path, PathBuf};

pub const FORMAT: &str = "twoscale-table/1";

/// `<table>.manifest.json` in `dir`.
pub fn manifest_path(dir: &Path, table: &str) -> PathBuf {
    dir.join(format!("{table}.manifest.json"))
}

/// `<table>.h5` in `dir`.
pub fn h5_path(dir: &Path, table: &str) -> PathBuf {
    dir.join(format!("{table}.h5"))
}

fn read_str_attr(loc: &hdf5::Location, name: &str) -> Result<String> {
    let v: VarLenUnicode = loc.attr(name)?.read_scalar()?;
    Ok(v.as_str().to_string())
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

/// Derived axes take the inputs their kind reads, in its order, each a
/// coordinate of the table (else a lookup could not compute them); every
/// encoded value names a stored value; control variates are zh_lobe's
/// four terms in the order of `Term::ALL`, each in a stored value of its own,
/// on the coordinates u, c, p, beta and theta_h, the last one derived
/// (zh_lobe's layout): every reader relies on it.
fn check_derived(manifest: &Manifest) -> Result<()> {
    let derived = |axis: &str| manifest.derived_axes.iter().find(|d| d.axis == axis);
    let names: Vec<&str> =
        manifest.axes.iter().map(|a| derived(&a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str())).collect();
    for d in &manifest.derived_axes {
        if d.inputs != d.derivation.inputs() {
            bail!("derived axis {} takes the inputs {:?}, not {:?}", d.axis, d.derivation.inputs(), d.inputs);
        }
        if let Some(missing) = d.inputs.iter().find(|n| !names.contains(&n.as_str())) {
            bail!(
                "derived axis {} reads {missing:?}, which is not a coordinate of the table ({})",
                d.axis,
                names.join(", ")
            );
        }
    }
    let stored = |name: &str| manifest.values.iter().any(|v| v.name == name);
    for e in &manifest.value_encoding {
        if !stored(&e.value) {
            bail!("value_encoding names {:?}, which is not a stored value", e.value);
        }
        if e.control_variates.is_empty() {
            continue;
        }
        let terms: Vec<Term> = e.control_variates.iter().map(|cv| cv.term).collect();
        if terms != Term::ALL {
            bail!("the control variates of {} must be the terms {:?} in that order, not {terms:?}", e.value, Term::ALL);
        }
        for cv in &e.control_variates {
            if cv.values == e.value || !stored(&cv.values) {
                bail!("control variate {:?} of {} is not a stored value of its own", cv.values, e.value);
            }
        }
        let lobe = ["u", "c", "p", "beta", "theta_h"];
        let last_derived =
            manifest.derived_axes.len() == 1 && names.len() == lobe.len() && derived(&manifest.axes[4].name).is_some();
        if names != lobe || !last_derived {
            bail!(
                "control variates need the coordinates {} (theta_h derived), not {}",
                lobe.join(", "),
                names.join(", ")
            );
        }
    }
    Ok(())
}

/// A cubic table has uniform axes of at least 4 nodes (its stencils are found from the cell and
/// weighted by node spacings), and no derived axes or encoded values (readers interpolate it plain).
fn check_interpolation(manifest: &Manifest) -> Result<()> {
    if manifest.interpolation != Interpolation::Cubic {
        return Ok(());
    }
    if let Some(a) = manifest.axes.iter().find(|a| !a.uniform || a.size < 4) {
        bail!(
            "cubic interpolation needs uniform axes of at least 4 nodes; axis {} has {} nodes, uniform {}",
            a.name,
            a.size,
            a.uniform
        );
    }
    if !manifest.derived_axes.is_empty() || !manifest.value_encoding.is_empty() {
        bail!("cubic interpolation takes no derived axes and no value encoding");
    }
    Ok(())
}

/// The manifest of `table` in `dir`: `<table>.manifest.json`, well-formed and naming `table`.
pub fn read_manifest(dir: &Path, table: &str) -> Result<Manifest> {
    let mpath = manifest_path(dir, table);
    let text = std::fs::read_to_string(&mpath).with_context(|| format!("cannot read {}", mpath.display()))?;
    let manifest: Manifest = serde_json::from_str(&text).with_context(|| {
        // The value encodings of 0.5.0 to 0.8.0 (ln_control_variates*) became stored control variates in 0.9.0.
        let old = text.contains("\"ln_control_variates");
        format!(
            "{}: malformed manifest{}",
            mpath.display(),
            if old { " (a value encoding from before twoscale 0.9.0: rebuild the table)" } else { "" }
        )
    })?;
    if manifest.format != crate::manifest::FORMAT {
        bail!(
            "{}: malformed manifest: format {:?}, not {:?}",
            mpath.display(),
            manifest.format,
            crate::manifest::FORMAT
        );
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
        bail!(
            "{}: malformed manifest: file.path is {:?}, not {expected:?}",
            manifest_path(dir, &manifest.table).display(),
            manifest.file.path
        );
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
        return Err(disagree("the contract (axis order and encodings, derived axes, value encodings, interpolation)"));
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
    check_derived(&manifest)
        .and_then(|()| check_interpolation(&manifest))
        .with_context(|| format!("{}: malformed manifest", mpath.display()))?;
    Ok((manifest, axes, contents.values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_derived_axis_must_read_coordinates_of_the_table() {
        let shipped: Manifest =
            serde_json::from_str(include_str!("../../../manifests/default/zh_lobe.manifest.json")).unwrap();
        check_derived(&shipped).unwrap();
        // beta renamed: the derived angle's input "beta" is no longer a coordinate (a lookup would have nothing to read).
        let mut renamed = shipped.clone();
        renamed.axes[3].name = "b".into();
        let err = check_derived(&renamed).unwrap_err().to_string();
        assert!(err.contains("reads \"beta\", which is not a coordinate"), "{err}");
        // Inputs in another order than the kind's are refused too.
        let mut swapped = shipped;
        swapped.derived_axes[0].inputs.swap(1, 2);
        assert!(check_derived(&swapped).unwrap_err().to_string().contains("takes the inputs"));
    }
}
