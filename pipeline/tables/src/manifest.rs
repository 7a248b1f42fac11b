//! The manifest beside each table file (docs/file_contract.md).

use crate::axis::{Axis, AxisEncoding};
use crate::checksum::sha256_f64;
use crate::derived::{DerivedAxis, EncodedValue};
use crate::interp::Interpolation;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;

pub const FORMAT: &str = "twoscale-manifest/1";

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Generator {
    pub name: String,
    pub version: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct AxisEntry {
    pub name: String,
    pub size: usize,
    /// JSON has no infinity: +inf is written as the string "inf".
    #[serde(serialize_with = "ser_f64", deserialize_with = "de_f64")]
    pub min: f64,
    #[serde(serialize_with = "ser_f64", deserialize_with = "de_f64")]
    pub max: f64,
    pub encoding: AxisEncoding,
    /// The encoding formula as text.
    pub encoding_formula: String,
    /// Nodes equally spaced in the encoding (a runtime may then find the cell
    /// directly instead of by search).
    pub uniform: bool,
    pub sha256: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ValueEntry {
    pub name: String,
    pub dtype: String,
    pub shape: Vec<usize>,
    pub sha256: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FileEntry {
    pub path: String,
    pub bytes: u64,
    pub sha256: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Manifest {
    pub format: String,
    pub table: String,
    pub preset: String,
    pub bundle_version: String,
    pub generator: Generator,
    pub definition: Value,
    pub axes: Vec<AxisEntry>,
    pub values: Vec<ValueEntry>,
    /// Stored axes computed from physical coordinates (docs/maths.md section 4b), if any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub derived_axes: Vec<DerivedAxis>,
    /// Stored values in an encoding (docs/maths.md section 4b), if any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub value_encoding: Vec<EncodedValue>,
    /// How values are interpolated between nodes (absent: multilinear; since 0.10.0 also cubic).
    #[serde(default, skip_serializing_if = "Interpolation::is_multilinear")]
    pub interpolation: Interpolation,
    pub file: FileEntry,
    pub accuracy: Value,
    pub settings: Value,
    pub timing: Value,
    /// What the build depended on, and its hash (for incremental builds).
    #[serde(default)]
    pub inputs: Value,
    /// A per-material table's material (docs/maths.md section 8): its name, every
    /// parameter, the wavelength range, N(p) and the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<Value>,
}

/// What a lookup reads from the manifest besides checksums and sizes: the
/// axes in order with their encodings, the value names in order, the derived
/// axes, the value encodings and the interpolation. The table file carries it too (root
/// attribute `contract`, JSON), and readers refuse a manifest that differs
/// from its verified file: no checksum covers these fields of the manifest.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Contract {
    pub axes: Vec<ContractAxis>,
    pub values: Vec<String>,
    pub derived_axes: Vec<DerivedAxis>,
    pub value_encoding: Vec<EncodedValue>,
    /// Absent from the files of multilinear tables (their bytes as before 0.10.0).
    #[serde(default, skip_serializing_if = "Interpolation::is_multilinear")]
    pub interpolation: Interpolation,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ContractAxis {
    pub name: String,
    pub encoding: AxisEncoding,
}

impl Contract {
    pub fn of_manifest(m: &Manifest) -> Contract {
        Contract {
            axes: m.axes.iter().map(|a| ContractAxis { name: a.name.clone(), encoding: a.encoding }).collect(),
            values: m.values.iter().map(|v| v.name.clone()).collect(),
            derived_axes: m.derived_axes.clone(),
            value_encoding: m.value_encoding.clone(),
            interpolation: m.interpolation,
        }
    }
}

fn ser_f64<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    if x.is_finite() {
        s.serialize_f64(*x)
    } else {
        s.serialize_str(if *x > 0.0 { "inf" } else { "-inf" })
    }
}

fn de_f64<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    match Value::deserialize(d)? {
        Value::Number(n) => n.as_f64().ok_or_else(|| serde::de::Error::custom("not a number")),
        Value::String(s) if s == "inf" => Ok(f64::INFINITY),
        Value::String(s) if s == "-inf" => Ok(f64::NEG_INFINITY),
        other => Err(serde::de::Error::custom(format!("expected a number or \"inf\", got {other}"))),
    }
}

pub fn axis_entry(axis: &Axis) -> AxisEntry {
    AxisEntry {
        name: axis.name.clone(),
        size: axis.len(),
        min: axis.min(),
        max: axis.max(),
        encoding: axis.encoding,
        encoding_formula: axis.encoding.formula(),
        uniform: axis.is_uniform(),
        sha256: sha256_f64(&axis.nodes),
    }
}

impl Manifest {
    /// The data checksums (axes then values), which CI compares.
    pub fn data_checksums(&self) -> Vec<(String, String)> {
        let axes = self.axes.iter().map(|a| (format!("axes/{}", a.name), a.sha256.clone()));
        let values = self.values.iter().map(|v| (format!("values/{}", v.name), v.sha256.clone()));
        axes.chain(values).collect()
    }
}
