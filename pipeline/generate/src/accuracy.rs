//! Measured accuracy of a table: error at the nodes against a reference,
//! and error after interpolation at random off-grid points.

use crate::numerics::sampling::SplitMix64;
use ndarray::ArrayD;
use rayon::prelude::*;
use serde_json::{json, Value};
use twoscale_tables::axis::Axis;
use twoscale_tables::interp::interpolate;

/// Largest absolute and relative errors over a set of points, with the worst one.
#[derive(Clone, Debug)]
pub struct ErrorStats {
    pub count: usize,
    pub max_abs: f64,
    /// Over references in f32's normal range (|r| >= 1.2e-38).
    pub max_rel: f64,
    pub rms_abs: f64,
    /// Point (physical coordinates), stored/interpolated value, reference value.
    pub worst: Option<(Vec<f64>, f64, f64)>,
    /// For node errors: how many stored f32 values differ from the f32
    /// rounding of the reference (0 = exact to the stored digit).
    pub f32_mismatches: Option<usize>,
    /// With a target: max |value - reference| / target(reference) (<= 1 meets
    /// it); the worst point is then the one with the largest such ratio.
    pub max_target_ratio: Option<f64>,
}

/// An accuracy target: the allowed error as a function of the reference value.
pub type Target = fn(f64) -> f64;

impl ErrorStats {
    /// Statistics of (point, value, reference) triples; the worst point is
    /// the one with the largest absolute error, or with the largest ratio to
    /// the target when one is given.
    pub fn from_samples(samples: &[(Vec<f64>, f64, f64)], target: Option<Target>) -> ErrorStats {
        let mut s = ErrorStats {
            count: samples.len(),
            max_abs: 0.0,
            max_rel: 0.0,
            rms_abs: 0.0,
            worst: None,
            f32_mismatches: None,
            max_target_ratio: target.map(|_| 0.0),
        };
        let mut sq = 0.0;
        let mut worst_key = -1.0;
        for (pt, v, r) in samples {
            let abs = (v - r).abs();
            sq += abs * abs;
            // f32 cannot hold relative precision below its normal range.
            if r.abs() >= f32::MIN_POSITIVE as f64 {
                s.max_rel = s.max_rel.max(abs / r.abs());
            }
            s.max_abs = s.max_abs.max(abs);
            let key = match target {
                Some(t) => {
                    let ratio = abs / t(*r);
                    s.max_target_ratio = s.max_target_ratio.map(|m| m.max(ratio));
                    ratio
                }
                None => abs,
            };
            if key > worst_key {
                worst_key = key;
                s.worst = Some((pt.clone(), *v, *r));
            }
        }
        s.rms_abs = if samples.is_empty() { 0.0 } else { (sq / samples.len() as f64).sqrt() };
        s
    }

    pub fn to_json(&self, axes: &[Axis]) -> Value {
        let worst = self.worst.as_ref().map(|(pt, v, r)| {
            let point: serde_json::Map<String, Value> =
                axes.iter().zip(pt).map(|(a, x)| (a.name.clone(), json_f64(*x))).collect();
            json!({ "point": point, "value": v, "reference": r })
        });
        let mut j = json!({
            "count": self.count,
            "max_abs": self.max_abs,
            "max_rel": self.max_rel,
            "max_rel_over": "references with |r| >= 1.2e-38 (f32 normal range)",
            "rms_abs": self.rms_abs,
            "worst": worst,
        });
        if let Some(m) = self.f32_mismatches {
            j["f32_mismatches"] = json!(m);
        }
        if let Some(m) = self.max_target_ratio {
            j["max_target_ratio"] = json!(m);
        }
        j
    }
}

/// A number for JSON (which has no infinity): +inf becomes "inf".
pub fn json_f64(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        json!(if x > 0.0 {
            "inf"
        } else if x < 0.0 {
            "-inf"
        } else {
            "nan"
        })
    }
}

/// Probe points, deterministic for a seed: even-numbered ones uniform in the
/// encoded coordinates of each axis, odd-numbered ones at the centre (in the
/// encoding) of a random cell, where multilinear interpolation errs most.
pub fn random_points(axes: &[Axis], count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|k| {
            axes.iter()
                .map(|axis| {
                    let e = axis.encoded();
                    let n = e.len();
                    let enc = if k % 2 == 0 {
                        e[0] + (e[n - 1] - e[0]) * rng.uniform()
                    } else {
                        let i = ((rng.uniform() * (n - 1) as f64) as usize).min(n - 2);
                        0.5 * (e[i] + e[i + 1])
                    };
                    axis.encoding.decode(enc).clamp(axis.min(), axis.max())
                })
                .collect()
        })
        .collect()
}

/// `groups` x `per_group` probe points whose first coordinate is shared within a group, for a
/// reference that needs a costly set-up per value of the first axis (epd_albedo's Lambda curve of a
/// p): the groups' first coordinates placed by `random_points` on the first axis, the other
/// coordinates of each group's points by `random_points` on the other axes (seed + group).
pub fn grouped_points(axes: &[Axis], groups: usize, per_group: usize, seed: u64) -> Vec<Vec<f64>> {
    random_points(&axes[..1], groups, seed)
        .into_iter()
        .enumerate()
        .flat_map(|(k, first)| {
            random_points(&axes[1..], per_group, seed + 1 + k as u64)
                .into_iter()
                .map(move |rest| [first.clone(), rest].concat())
        })
        .collect()
}

/// Interpolation error of `values` at `count` random points against `exact`.
pub fn interpolation_error(
    axes: &[Axis],
    values: &ArrayD<f32>,
    count: usize,
    seed: u64,
    exact: impl Fn(&[f64]) -> f64 + Sync,
    target: Option<Target>,
) -> ErrorStats {
    let samples: Vec<(Vec<f64>, f64, f64)> = random_points(axes, count, seed)
        .into_par_iter()
        .map(|pt| {
            let v = interpolate(axes, &values.view(), &pt).expect("probe inside the domain");
            let r = exact(&pt);
            (pt, v, r)
        })
        .collect();
    ErrorStats::from_samples(&samples, target)
}

/// Error of the stored values at every `stride`-th node (flat C order) against `reference`.
pub fn node_error(
    axes: &[Axis],
    values: &ArrayD<f32>,
    stride: usize,
    reference: impl Fn(&[f64]) -> f64 + Sync,
) -> ErrorStats {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let flat: Vec<f32> = values.iter().copied().collect();
    let samples: Vec<(Vec<f64>, f64, f64)> = (0..flat.len())
        .step_by(stride.max(1))
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|k| {
            let mut rem = k;
            let mut pt = vec![0.0; shape.len()];
            for d in (0..shape.len()).rev() {
                pt[d] = axes[d].nodes[rem % shape[d]];
                rem /= shape[d];
            }
            let r = reference(&pt);
            (pt, flat[k] as f64, r)
        })
        .collect();
    let mismatches = samples.iter().filter(|(_, v, r)| *v as f32 != *r as f32).count();
    ErrorStats { f32_mismatches: Some(mismatches), ..ErrorStats::from_samples(&samples, None) }
}

/// The `accuracy` section of a manifest: node error and interpolation error,
/// each with what was measured, plus table-specific notes in `extra`.
pub struct AccuracyReport<'a> {
    pub axes: &'a [Axis],
    pub node_what: &'a str,
    pub node_stride: usize,
    pub node: &'a ErrorStats,
    pub interp_what: &'a str,
    pub interp_seed: u64,
    pub interp: &'a ErrorStats,
}

impl AccuracyReport<'_> {
    pub fn to_json(&self, extra: Value) -> Value {
        let mut j = json!({
            "node_error": { "what": self.node_what, "stride": self.node_stride, "stats": self.node.to_json(self.axes) },
            "interpolation_error": {
                "what": self.interp_what,
                "seed": self.interp_seed,
                "stats": self.interp.to_json(self.axes),
            },
        });
        if let (Value::Object(m), Value::Object(e)) = (&mut j, extra) {
            m.extend(e);
        }
        j
    }
}

/// How interpolation probes are placed (shared wording for manifests).
pub const PROBES_WHAT: &str = "multilinear interpolation of the stored f32 values in encoded coordinates \
    (as `twoscale lookup`) against a direct evaluation, at random points: half uniform in the encoded \
    coordinates of each axis, half at centres (in the encoding) of random cells";

/// The standard measurement of a table: node error at about 5,000 nodes
/// against `reference` (described by `node_what`), and interpolation error at
/// `probes` random points against `direct` (with an optional target), as the
/// manifest's `accuracy` section with `extra` merged in.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    axes: &[Axis],
    values: &ArrayD<f32>,
    node_what: &str,
    reference: impl Fn(&[f64]) -> f64 + Sync,
    direct: impl Fn(&[f64]) -> f64 + Sync,
    probes: usize,
    target: Option<Target>,
    extra: Value,
) -> Value {
    let stride = (values.len() / 5000).max(1);
    let node = node_error(axes, values, stride, reference);
    let interp = interpolation_error(axes, values, probes, PROBE_SEED, direct, target);
    AccuracyReport {
        axes,
        node_what,
        node_stride: stride,
        node: &node,
        interp_what: PROBES_WHAT,
        interp_seed: PROBE_SEED,
        interp: &interp,
    }
    .to_json(extra)
}

/// Seed of the interpolation probes (fixed: manifests are reproducible).
pub const PROBE_SEED: u64 = 0x7477_6f73_6361_6c65;
