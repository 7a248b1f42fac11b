//! The GPU export `twoscale-webgl/1` (runtimes/webgl/README.md): one
//! material's tables as raw little-endian float32 textures, `<table>.bin`,
//! beside a JSON descriptor, `material.json`, as glTF keeps its buffers. Raw
//! float32 because WebGL2 uploads it as it is (`texImage2D(.., FLOAT, data)`):
//! no decoder (KTX2, EXR) in the page, and the texels are the HDF5 file's
//! values bit for bit (twoscale_brdf.glsl reads them with `texelFetch` and
//! interpolates itself, so no float16 fallback is ever needed).

use anyhow::{bail, Context, Result};
use serde::{Serialize, Serializer};
use twoscale_tables::axis::AxisEncoding;
use twoscale_tables::checksum::sha256_bytes;
use twoscale_tables::derived::DerivedAxis;
use twoscale_tables::file::TableData;
use twoscale_tables::manifest::Generator;

pub const FORMAT: &str = "twoscale-webgl/1";
/// The descriptor's file name, beside the binaries.
pub const DESCRIPTOR: &str = "material.json";
/// The checksums of every other file, the descriptor's included, last.
pub const SUMS: &str = "SHA256SUMS";

/// The export's files of one material (its tables as read, in the order of
/// `Material::table_names`): (file name, bytes), the binaries first, then the
/// descriptor, then SHA256SUMS, the order to write them in (a reader that
/// finds the descriptor finds its binaries). An error when a table is not one
/// the GPU runtime reads as the C BRDF does: more than two axes (a texture has
/// two), an axis not uniform in its encoding, cubic interpolation.
pub fn export_files(tables: &[TableData]) -> Result<Vec<(String, Vec<u8>)>> {
    let (first, _, _) = tables.first().context("no table to export")?;
    let material = first.material.as_ref().with_context(|| format!("{}: no material section", first.table))?;
    let wavelength = |k: &str| material.get(k).and_then(serde_json::Value::as_f64);
    let mut files = Vec::new();
    let mut entries = Vec::new();
    for table in tables {
        let (bytes, entry) = table_export(table)?;
        files.push((entry.file.clone(), bytes));
        entries.push(entry);
    }
    let descriptor = Descriptor {
        format: FORMAT,
        generator: crate::build::generator(),
        preset: &first.preset,
        material,
        wavelength_range: wavelength("wavelength_min").zip(wavelength("wavelength_max")).map(|(a, b)| [a, b]),
        tables: entries,
    };
    files.push((DESCRIPTOR.to_string(), (serde_json::to_string_pretty(&descriptor)? + "\n").into_bytes()));
    push_sums(&mut files);
    Ok(files)
}

/// Appends SHA256SUMS to an export's files: last, covering the descriptor too (its numbers have no other
/// checksum), in name order: `sha256sum -c`.
pub(crate) fn push_sums(files: &mut Vec<(String, Vec<u8>)>) {
    let mut sums: Vec<String> =
        files.iter().map(|(name, bytes)| format!("{}  {name}\n", sha256_bytes(bytes))).collect();
    sums.sort_by(|a, b| a[66..].cmp(&b[66..]));
    files.push((SUMS.to_string(), sums.concat().into_bytes()));
}

/// The descriptor; the fields in the README's order (a struct fixes the key order: serde_json's
/// maps sort their keys).
#[derive(Serialize)]
struct Descriptor<'a> {
    format: &'static str,
    generator: Generator,
    preset: &'a str,
    material: &'a serde_json::Value,
    /// Micrometres; null for a material without diffraction (its manifests have no wavelengths).
    wavelength_range: Option<[f64; 2]>,
    tables: Vec<TableEntry<'a>>,
}

#[derive(Serialize)]
struct TableEntry<'a> {
    table: &'a str,
    file: String,
    bytes: usize,
    sha256: String,
    values: Vec<&'a str>,
    texture: Texture,
    axes: Vec<AxisEntry<'a>>,
    derived_axes: &'a [DerivedAxis],
    data_sha256: Checksums<'a>,
}

#[derive(Serialize)]
struct Texture {
    format: Format,
    width: usize,
    height: usize,
}

/// One texture's format, one channel per value; a table of more than four values (albedo's five)
/// is several textures over the same texels, texture k holding values 4k..4k+3.
#[derive(Serialize)]
#[serde(untagged)]
enum Format {
    One(&'static str),
    Split(Vec<&'static str>),
}

#[derive(Serialize)]
struct AxisEntry<'a> {
    name: &'a str,
    size: usize,
    #[serde(serialize_with = "json_f64")]
    min: f64,
    #[serde(serialize_with = "json_f64")]
    max: f64,
    encoding: AxisEncoding,
    encoding_formula: &'a str,
    encoded_first: f64,
    encoded_last: f64,
}

/// The manifest's data checksum of each value, as an object in channel order.
struct Checksums<'a>(Vec<(&'a str, &'a str)>);

impl Serialize for Checksums<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().copied())
    }
}

/// As the manifests write it: JSON has no infinity, +inf is the string "inf".
pub(crate) fn json_f64<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    if x.is_finite() {
        s.serialize_f64(*x)
    } else {
        s.serialize_str(if *x > 0.0 { "inf" } else { "-inf" })
    }
}

/// The texture format of `channels` float32 channels.
fn format(channels: usize) -> &'static str {
    ["R32F", "RG32F", "RGB32F", "RGBA32F"][channels - 1]
}

/// One table's binary (the values interleaved per node, C order) and its descriptor entry.
fn table_export((manifest, axes, values): &TableData) -> Result<(Vec<u8>, TableEntry<'_>)> {
    let table = manifest.table.as_str();
    if !manifest.interpolation.is_multilinear() {
        bail!("{table}: cubic interpolation; the GPU runtime interpolates linearly");
    }
    if axes.is_empty() || axes.len() > 2 || values.is_empty() {
        bail!("{table}: {} axes and {} values, a texture takes one or two axes", axes.len(), values.len());
    }
    // The shader finds a cell as floor((e - e0) / step), as the C BRDF does: nodes equally spaced in e.
    if let Some(a) = manifest.axes.iter().find(|a| !a.uniform) {
        bail!(
            "{table}: axis {} is not uniform in its encoding ({}), as the runtimes' cell lookup needs",
            a.name,
            a.encoding_formula
        );
    }
    let nodes: usize = axes.iter().map(|a| a.len()).product();
    let shape: Vec<usize> = axes.iter().map(|a| a.len()).collect();
    if let Some((name, _)) = values.iter().find(|(_, v)| v.shape() != shape.as_slice()) {
        bail!("{table}: value {name} is not of the axes' shape {shape:?}");
    }
    let columns: Vec<Vec<f32>> = values.iter().map(|(_, v)| v.iter().copied().collect()).collect();
    let mut bytes = Vec::with_capacity(nodes * values.len() * 4);
    for n in 0..nodes {
        for column in &columns {
            bytes.extend_from_slice(&column[n].to_le_bytes());
        }
    }
    let channels = values.len();
    let format = if channels <= 4 {
        Format::One(format(channels))
    } else {
        Format::Split((0..channels).step_by(4).map(|c| format((channels - c).min(4))).collect())
    };
    let entry = TableEntry {
        table,
        file: format!("{table}.bin"),
        bytes: bytes.len(),
        sha256: sha256_bytes(&bytes),
        values: values.iter().map(|(n, _)| n.as_str()).collect(),
        texture: Texture {
            format,
            width: axes[axes.len() - 1].len(),
            height: if axes.len() == 2 { axes[0].len() } else { 1 },
        },
        axes: axes
            .iter()
            .zip(&manifest.axes)
            .map(|(a, e)| AxisEntry {
                name: &e.name,
                size: e.size,
                min: e.min,
                max: e.max,
                encoding: e.encoding,
                encoding_formula: &e.encoding_formula,
                encoded_first: a.encoded()[0],
                encoded_last: a.encoded()[a.len() - 1],
            })
            .collect(),
        derived_axes: &manifest.derived_axes,
        data_sha256: Checksums(manifest.values.iter().map(|v| (v.name.as_str(), v.sha256.as_str())).collect()),
    };
    Ok((bytes, entry))
}
