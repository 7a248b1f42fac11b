//! The general GPU export `twoscale-webgl-general/1` (runtimes/webgl/README.md "The general
//! export"): the default preset's general tables, everything a shader needs for any (beta, p,
//! sigma_s, b, c) of the default domain, in the material export's container (raw little-endian
//! binaries, a JSON descriptor `tables.json`, `SHA256SUMS` last). At most 64 MB.
//!
//! zh_lobe is 310 MB as stored: ln C and its four control-variate terms at 15.5 M nodes. Here it is
//! one float16 per node, the residual of ln C from its control-variate model M at the node, and the
//! reader computes the terms at the cell's 32 corners itself (docs/maths.md section 4b):
//!
//! ```text
//! r = ln C - M at the nodes,  M = sum_j alpha_j t_j  (alpha_j, t_j at the node)
//! ln C(x) = I[r](x) + I[M](x) + sum_j alpha_j(x) (t_j(x) - I[t_j](x))
//! ```
//!
//! which is the table's own decoding with ln C = r + M: the corners' terms are the stored control
//! variates, recomputed. |r| is small (median 0.13, where |ln C| reaches 27), so float16 rounds it to
//! a few 1e-6 of C typically. Measured choices (docs/benchmarks.md "The general export for GPUs"):
//! ln C itself in float16 errs 10 times more at the 99th percentile; any halved axis errs by
//! percent.
//!
//! kcorr_renorm is cut to the nodes covering the domain (B in [0.1, 100], c in [1.02, 3.02]); every
//! other table is its float32 values as stored.

use super::webgl::{json_f64, push_sums};
use anyhow::{bail, ensure, Context, Result};
use half::f16;
use ndarray::ArrayD;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::{json, Value};
use twoscale_tables::axis::Axis;
use twoscale_tables::checksum::sha256_bytes;
use twoscale_tables::derived::{Derivation, DerivedAxis, EncodedValue};
use twoscale_tables::file::TableData;
use twoscale_tables::interp::Interpolation;
use twoscale_tables::lobe::{weights, LobeParams, LobeTerms};
use twoscale_tables::lookup::Lookup;
use twoscale_tables::manifest::Generator;

pub const FORMAT: &str = "twoscale-webgl-general/1";
/// The descriptor's file name, beside the binaries.
pub const DESCRIPTOR: &str = "tables.json";
/// The default preset's tables the export holds, in its order.
pub const TABLES: [&str; 8] =
    ["epd_g1", "epd_norm", "epd_quantile", "kcorr_renorm", "zh_convolution", "zh_lobe", "epd_albedo", "epd_albedo_avg"];
/// The domain's B = b / lambda and c that kcorr_renorm is cut to: b in [0.083, 36] um over lambda in
/// [0.36, 0.83] um reads B in [0.1, 100]; c is zh_lobe's.
const KCORR_B: (f64, f64) = (0.1, 100.0);
const KCORR_C: (f64, f64) = (1.02, 3.02);
/// The accuracy probes of zh_lobe: parameter points (uniform in the encoded axes) times angles.
const PROBE_POINTS: usize = 2000;
const PROBE_ANGLES: usize = 100;
const PROBE_SEED: u64 = 61;

/// The export's files of the default preset's `tables` (as read, each named by TABLES): the
/// binaries, then the descriptor, then SHA256SUMS, the order to write them in. Takes the tables: zh_lobe's
/// values (310 MB) move into the lookup that measures the export's accuracy, not copied.
pub fn export_files(tables: Vec<TableData>) -> Result<Vec<(String, Vec<u8>)>> {
    ensure!(tables.len() == TABLES.len(), "the general export takes the tables {}", TABLES.join(", "));
    let mut files = Vec::new();
    let mut entries = Vec::new();
    for (table, name) in tables.into_iter().zip(TABLES) {
        let (manifest, _, _) = &table;
        ensure!(manifest.table == name, "expected table {name}, got {}", manifest.table);
        ensure!(
            manifest.preset == "default",
            "{name}: the general export is of the default preset, not {}",
            manifest.preset
        );
        let (bytes, entry) = match name {
            "zh_lobe" => lobe_entry(table)?,
            "kcorr_renorm" => {
                let cut = cut(&table, &[(1, KCORR_B), (2, KCORR_C)])?;
                let (bytes, mut entry) = f32_entry(&cut)?;
                entry.accuracy = json!({"what": "the stored float32 values at the nodes covering B in [0.1, 100] and c in [1.02, 3.02]: \
                                                  exactly the table's lookup there", "max_rel": 0.0});
                (bytes, entry)
            }
            _ => f32_entry(&table)?,
        };
        files.push((entry.file.clone(), bytes));
        entries.push(entry);
    }
    let descriptor = Descriptor {
        format: FORMAT,
        generator: crate::build::generator(),
        preset: "default",
        domain: json!({
            "beta": [0.005, 0.5], "p": [0.05, 5.0], "p_diffraction": [0.2, 5.0], "sigma_s": [0.0, "inf"],
            "b": [0.083, 36.0], "c": [1.02, 3.02], "wavelength": [0.36, 0.83],
        }),
        tables: entries,
    };
    files.push((DESCRIPTOR.to_string(), (serde_json::to_string_pretty(&descriptor)? + "\n").into_bytes()));
    push_sums(&mut files);
    Ok(files)
}

/// The descriptor, fields in the README's order.
#[derive(Serialize)]
struct Descriptor {
    format: &'static str,
    generator: Generator,
    preset: &'static str,
    /// The parameters' domain ({name: [min, max]}, micrometres).
    domain: Value,
    tables: Vec<Entry>,
}

/// One table: its binary (values interleaved per node, C order over the axes), how to read it,
/// and how far its values are from the table's own lookup.
#[derive(Serialize)]
struct Entry {
    table: String,
    file: String,
    bytes: usize,
    sha256: String,
    /// `float32` or `float16` (IEEE binary16), little-endian.
    dtype: &'static str,
    values: Vec<String>,
    shape: Vec<usize>,
    axes: Vec<AxisOut>,
    derived_axes: Vec<DerivedAxis>,
    value_encoding: Vec<EncodedValue>,
    interpolation: Interpolation,
    /// How the values decode, where that differs from the manifest's (zh_lobe).
    #[serde(skip_serializing_if = "Option::is_none")]
    decoding: Option<String>,
    accuracy: Value,
    /// The manifest's data checksums ({value: sha256}): the HDF5 datasets these values come from.
    data_sha256: std::collections::BTreeMap<String, String>,
}

/// An axis: the manifest's entry (`uniform` implied) plus its first and last encoded nodes.
#[derive(Serialize)]
struct AxisOut {
    name: String,
    size: usize,
    #[serde(serialize_with = "json_f64")]
    min: f64,
    #[serde(serialize_with = "json_f64")]
    max: f64,
    encoding: twoscale_tables::axis::AxisEncoding,
    encoding_formula: String,
    encoded_first: f64,
    encoded_last: f64,
}

fn axes_out(axes: &[Axis]) -> Vec<AxisOut> {
    axes.iter()
        .map(|a| AxisOut {
            name: a.name.clone(),
            size: a.len(),
            min: a.min(),
            max: a.max(),
            encoding: a.encoding,
            encoding_formula: a.encoding.formula(),
            encoded_first: a.encoded()[0],
            encoded_last: a.encoded()[a.len() - 1],
        })
        .collect()
}

fn entry(table: &TableData, values: Vec<String>, dtype: &'static str, bytes: &[u8]) -> Result<Entry> {
    let (manifest, axes, _) = table;
    if let Some(a) = axes.iter().find(|a| !a.is_uniform()) {
        bail!("{}: axis {} is not uniform in its encoding, as the shader's cell lookup needs", manifest.table, a.name);
    }
    Ok(Entry {
        table: manifest.table.clone(),
        file: format!("{}.bin", manifest.table),
        bytes: bytes.len(),
        sha256: sha256_bytes(bytes),
        dtype,
        values,
        shape: axes.iter().map(Axis::len).collect(),
        axes: axes_out(axes),
        derived_axes: manifest.derived_axes.clone(),
        value_encoding: manifest.value_encoding.clone(),
        interpolation: manifest.interpolation,
        decoding: None,
        accuracy: json!({"what": "the stored float32 values: exactly the table's lookup", "max_rel": 0.0}),
        data_sha256: manifest.values.iter().map(|v| (v.name.clone(), v.sha256.clone())).collect(),
    })
}

/// A table's float32 values interleaved per node.
fn f32_entry(table: &TableData) -> Result<(Vec<u8>, Entry)> {
    let (_, _, values) = table;
    let columns: Vec<&ArrayD<f32>> = values.iter().map(|(_, v)| v).collect();
    let nodes = columns[0].len();
    let flat: Vec<&[f32]> = columns.iter().map(|v| v.as_slice().expect("C order")).collect();
    let mut bytes = Vec::with_capacity(nodes * flat.len() * 4);
    for n in 0..nodes {
        for column in &flat {
            bytes.extend_from_slice(&column[n].to_le_bytes());
        }
    }
    let names = values.iter().map(|(n, _)| n.clone()).collect();
    let entry = entry(table, names, "float32", &bytes)?;
    Ok((bytes, entry))
}

/// The table restricted, on each (axis, (lo, hi)), to the nodes covering [lo, hi].
fn cut(table: &TableData, ranges: &[(usize, (f64, f64))]) -> Result<TableData> {
    let (manifest, axes, values) = table;
    let mut keep: Vec<std::ops::RangeInclusive<usize>> = axes.iter().map(|a| 0..=a.len() - 1).collect();
    for &(i, (lo, hi)) in ranges {
        keep[i] = axes[i]
            .covering(lo, hi)
            .with_context(|| format!("{}: the domain leaves axis {}", manifest.table, axes[i].name))?;
    }
    let new_axes: Vec<Axis> = axes.iter().zip(&keep).map(|(a, k)| a.slice(k.clone())).collect();
    let slice: Vec<ndarray::SliceInfoElem> =
        keep.iter().map(|k| ndarray::Slice::from(*k.start()..*k.end() + 1).into()).collect();
    let new_values =
        values.iter().map(|(n, v)| (n.clone(), v.slice(slice.as_slice()).as_standard_layout().into_owned())).collect();
    Ok((manifest.clone(), new_axes, new_values))
}

/// zh_lobe as the float16 residual r = ln C - M (module docs), with its measured accuracy.
fn lobe_entry(table: TableData) -> Result<(Vec<u8>, Entry)> {
    let (manifest, axes, values) = (&table.0, &table.1, &table.2);
    let derivation = match manifest.derived_axes.as_slice() {
        [d] if matches!(d.derivation, Derivation::AnchoredLobeAngle { .. }) => d.derivation,
        _ => bail!("zh_lobe: its angle is not an anchored_lobe_angle (not the default preset's table)"),
    };
    let ln_c = &values.iter().find(|(n, _)| n == "c_lobe").context("zh_lobe: no value c_lobe")?.1;
    let lobe = ResidualLobe::new(axes, derivation, ln_c.as_slice().expect("C order"));
    let bytes: Vec<u8> = lobe.r.iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut e = entry(&table, vec!["ln_c_residual".into()], "float16", &bytes)?;
    e.value_encoding = vec![];
    e.decoding = Some(DECODING.into());
    // the values move into the lookup (the residual's axes, small, are copied)
    let full = Lookup::new(
        manifest.table.clone(),
        axes.clone(),
        table.2,
        manifest.derived_axes.clone(),
        manifest.value_encoding.clone(),
        manifest.interpolation,
    );
    e.accuracy = lobe.accuracy(&full);
    Ok((bytes, e))
}

/// zh_lobe's decoding from the float16 residual, as the descriptor states it.
pub const DECODING: &str = "ln_c_residual = ln C - M at the nodes, M = sum_j alpha_j t_j with the weights alpha_j and terms t_j \
    of zh_lobe's control variates (manifest value_encoding; docs/maths.md section 4b) at the node, its angle theta_node = the \
    derived axis's inverse at (v node; u, p, beta nodes). C(x) = exp(I[ln_c_residual](x) + sum_k w_k M_k + sum_j alpha_j(x) \
    (t_j(x) - sum_k w_k t_jk)), sums over the cell's 32 corners k with multilinear weights w_k, t_jk and M_k at corner k; \
    alpha_j(x) and t_j(x) at the query point (a term of weight alpha_j(x) = 0 adds nothing)";

/// zh_lobe as its float16 residual, and the decoding a shader does (the reference for twoscale_brdf.glsl).
pub struct ResidualLobe<'a> {
    axes: &'a [Axis],
    derivation: Derivation,
    /// The residual per node, C order over (u, c, p, beta, v).
    r: Vec<f16>,
}

impl<'a> ResidualLobe<'a> {
    /// The residual of ln C (`ln_c` over `axes`) from M, rounded to float16.
    pub fn new(axes: &'a [Axis], derivation: Derivation, ln_c: &[f32]) -> ResidualLobe<'a> {
        let nv = axes[4].len();
        let (nu, nc, np, nb) = (axes[0].len(), axes[1].len(), axes[2].len(), axes[3].len());
        let r = (0..nu * nc * np * nb)
            .into_par_iter()
            .flat_map_iter(|k| {
                let (iu, ic, ip, ib) = (k / (nc * np * nb), k / (np * nb) % nc, k / nb % np, k % nb);
                let x = LobeParams {
                    u: axes[0].nodes[iu],
                    c: axes[1].nodes[ic],
                    p: axes[2].nodes[ip],
                    beta: axes[3].nodes[ib],
                };
                let terms = LobeTerms::new(&x);
                (0..nv)
                    .map(|iv| {
                        let v = axes[4].nodes[iv];
                        let (m, _) = model(&x, &terms, derivation, v);
                        f16::from_f64(f64::from(ln_c[k * nv + iv]) - m)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        ResidualLobe { axes, derivation, r }
    }

    /// C at (u, c, p, beta, theta_h): the decoding of `DECODING`.
    pub fn at(&self, x: &LobeParams, theta: f64) -> Result<f64> {
        let inputs = [x.u, x.p, x.beta];
        let v = self.derivation.forward(theta, &inputs);
        let coords = [x.u, x.c, x.p, x.beta, v];
        let cells: Vec<(usize, f64)> =
            self.axes.iter().zip(coords).map(|(a, c)| a.locate(c)).collect::<Result<_, _>>()?;
        let shape: Vec<usize> = self.axes.iter().map(Axis::len).collect();
        let (mut ln_c, mut interpolated) = (0.0, [0.0; 4]);
        for corner in 0..32 {
            let (mut w, mut offset) = (1.0, 0);
            let mut node = [0usize; 5];
            for d in 0..5 {
                let (i, t) = cells[d];
                let up = corner >> (4 - d) & 1;
                node[d] = i + up;
                w *= if up == 1 { t } else { 1.0 - t };
                offset = offset * shape[d] + node[d];
            }
            if w == 0.0 {
                continue;
            }
            let n = |d: usize| self.axes[d].nodes[node[d]];
            let xk = LobeParams { u: n(0), c: n(1), p: n(2), beta: n(3) };
            let (m, t) = model(&xk, &LobeTerms::new(&xk), self.derivation, n(4));
            ln_c += w * (self.r[offset].to_f64() + m);
            for (s, tj) in interpolated.iter_mut().zip(t) {
                *s += w * tj;
            }
        }
        Ok((ln_c + twoscale_tables::lobe::correction(theta, x, v, interpolated)).exp())
    }

    /// Relative error of `at` against the full table's lookup at random points: parameter points
    /// uniform in the encoded axes, each at angles sin theta = 1 - k/1000 for random k, where C >= 1e-4
    /// of the point's largest over those angles (as zh_lobe's own manifest measures).
    fn accuracy(&self, full: &Lookup) -> Value {
        let mut rng = crate::numerics::sampling::SplitMix64::new(PROBE_SEED);
        let points: Vec<(LobeParams, Vec<f64>)> = (0..PROBE_POINTS)
            .map(|_| {
                let mut at = |d: usize| {
                    let e = self.axes[d].encoded();
                    self.axes[d].encoding.decode(e[0] + rng.uniform() * (e[e.len() - 1] - e[0]))
                };
                let x = LobeParams { u: at(0), c: at(1), p: at(2), beta: at(3) };
                let thetas =
                    (0..PROBE_ANGLES).map(|_| (1.0 - (rng.uniform() * 1000.0).floor() / 1000.0).asin()).collect();
                (x, thetas)
            })
            .collect();
        let mut rel: Vec<f64> = points
            .par_iter()
            .flat_map_iter(|(x, thetas)| {
                let pairs: Vec<(f64, f64)> = thetas
                    .iter()
                    .map(|&th| {
                        let want = full.decode(&[x.u, x.c, x.p, x.beta, th]).expect("inside")[0];
                        (self.at(x, th).expect("inside"), want)
                    })
                    .collect();
                let peak = pairs.iter().fold(0.0f64, |m, p| m.max(p.1));
                pairs.into_iter().filter(move |p| p.1 >= 1e-4 * peak).map(|(got, want)| (got - want).abs() / want)
            })
            .collect();
        rel.sort_by(f64::total_cmp);
        let q = |f: f64| rel[((rel.len() - 1) as f64 * f).round() as usize];
        json!({
            "what": format!("relative error of C decoded from the float16 residual (`decoding`) against zh_lobe's own lookup \
                             (float32 ln C and its control variates) at {PROBE_POINTS} random (u, c, p, beta), uniform in the \
                             encoded axes, each at {PROBE_ANGLES} angles sin theta_h = 1 - k/1000 (k random), where C >= 1e-4 \
                             of the point's largest there"),
            "samples": rel.len(),
            "median": q(0.5),
            "p99": q(0.99),
            "max": rel[rel.len() - 1],
        })
    }
}

/// (M, t): the control-variate model M = sum_j alpha_j t_j at stored angle v of the parameter point
/// `x` (a node, or any point), and the terms t_j; terms of weight 0 add nothing to M.
fn model(x: &LobeParams, terms: &LobeTerms, derivation: Derivation, v: f64) -> (f64, [f64; 4]) {
    let theta = derivation.inverse(v, &[x.u, x.p, x.beta]);
    let t = terms.at(theta, [true; 4]);
    let alpha = weights(x.u, x.p, x.beta, v);
    let m = (0..4).filter(|&j| alpha[j] != 0.0).map(|j| alpha[j] * t[j]).sum();
    (m, t)
}
