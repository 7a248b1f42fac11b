//! Stage `epd-albedo`: `epd_albedo`, the directional albedo E(theta_i; p, beta) of the EPD
//! microfacet lobe (docs/maths.md section 9, `epd_albedo_math`), and `epd_albedo_avg`, its
//! hemispherical average E_avg(p, beta) = 2 int_0^1 E(mu) mu dmu. Both are interpolated cubically
//! (4-point Lagrange per axis, manifest `interpolation`): multilinear interpolation needs ~100
//! million nodes for 1e-4 where cubic needs a few million (measured: docs/maths.md section 9).

use super::context::BuildContext;
use super::epd_albedo_column::{albedo_column, rule_text};
use super::epd_albedo_math::{albedo_reference_with, theta_average, LambdaCurve, MU_MIN, REFERENCE_CURVE_NODES};
use super::job::{Built, Job, Part, Units};
use super::lambda_table::LambdaTable;
use super::options::BuildOptions;
use super::preset::Preset;
use super::sub_domain::sub_domain;
use super::table_def::TableDef;
use crate::accuracy::{grouped_points, AccuracyReport, ErrorStats};
use crate::numerics::quadrature::integrate;
use crate::progress::Progress;
use anyhow::Result;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::sync::Arc;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::derived::Derived;
use twoscale_tables::interp::{cubic_weights, Interpolation};
use twoscale_tables::lookup::Lookup;
use twoscale_tables::table::Table;

pub const EPD_ALBEDO: TableDef = TableDef {
    name: "epd_albedo",
    stage: "epd-albedo",
    definition:
        "docs/maths.md section 9: e = E(theta_i; p, beta) = int D(h) G2(i, o) / (4 cos theta_i) do over o_z > 0, \
                 the directional albedo of the EPD microfacet lobe (SPEC section 7's specular part with A = 1, F = 1); \
                 cubic interpolation (manifest interpolation)",
    axes: albedo_axes,
    diffraction: false,
    cubic: true,
    job: job_albedo,
    presets: &[Preset::Default],
};

pub const EPD_ALBEDO_AVG: TableDef = TableDef {
    name: "epd_albedo_avg",
    stage: "epd-albedo",
    definition: "docs/maths.md section 9: e_avg = E_avg(p, beta) = 2 int_0^1 E(mu) mu dmu of epd_albedo's E; cubic \
                 interpolation (manifest interpolation)",
    axes: avg_axes,
    diffraction: false,
    cubic: true,
    job: job_avg,
    presets: &[Preset::Default],
};

/// Nodes uniform in 1/p (as epd_g1), ln beta (as zh_convolution) and theta_i's bounded_log_tan,
/// spacings 0.125, 0.070 and 0.071. Measured after cubic interpolation against the rule (local
/// stencils, 1,800 points): 3.3e-5 at most, where spacings of 0.1 on all three left 1.05e-4 at
/// large p, small beta and mu ~ 2 beta (the near-kink of the disk-like slope density, along beta
/// and theta_i); the p axis contributes least (7e-6 at 0.1).
/// theta_i's encoding is ln tan theta_i from tan theta_i = 1e-5 (eps) to the axis' end, acos(MU_MIN)
/// (tan = 1e6, delta tan = 0.01), finite at 0.
const NP: usize = 160;
const NB: usize = 67;
const NT: usize = 356;
const THETA: AxisEncoding = AxisEncoding::BoundedLogTan { eps: 1e-5, delta: 1e-8 };
/// Interpolation probes, nodes measured, and their reference's relative tolerance. The reference
/// needs a Lambda curve per p (0.14 s): probes come in groups of one p each (GROUP_SIZE points),
/// nodes on NODE_GROUPS p nodes.
const PROBES: usize = 2000;
const NODES_MEASURED: usize = 500;
const AVG_PROBES: usize = 100;
const AVG_NODES_MEASURED: usize = 40;
const GROUP_SIZE: usize = 40;
const NODE_GROUPS: usize = 20;
const REFERENCE_TOL: f64 = 1e-9;
const SEED: u64 = 0x6561;
pub const TARGET: f64 = 1e-4;

/// Axes (p, beta, theta_i) of `epd_albedo`.
pub fn albedo_axes(_: Preset) -> Vec<Axis> {
    vec![
        Axis::uniform("p", AxisEncoding::Reciprocal, 5.0, 0.05, NP),
        Axis::uniform("beta", AxisEncoding::Log, 0.005, 0.5, NB),
        Axis::uniform("theta_i", THETA, 0.0, MU_MIN.acos(), NT),
    ]
}

/// Axes (p, beta) of `epd_albedo_avg`.
pub fn avg_axes(preset: Preset) -> Vec<Axis> {
    albedo_axes(preset).into_iter().take(2).collect()
}

/// E(theta_i) at every theta_i node for each (p, beta) node, f64, from the build's context
/// (computed once per build) or computed now: one Lambda table per p, one column per beta.
fn columns(context: &Option<Arc<BuildContext>>, p: f64, betas: &[f64], theta: &Axis) -> Vec<Arc<Vec<f64>>> {
    let compute = |betas: &[f64]| -> Vec<Vec<f64>> {
        let table = LambdaTable::new(p);
        betas.par_iter().map(|&beta| albedo_column(&table, beta, &theta.nodes)).collect()
    };
    match context {
        Some(c) => c.albedo_columns(p, betas, theta.len(), compute),
        None => compute(betas).into_iter().map(Arc::new).collect(),
    }
}

fn job_albedo(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let axes = sub_domain(albedo_axes(preset), EPD_ALBEDO.cubic, options)?;
    Ok(Box::new(AlbedoJob { axes, avg: false, context: options.context.clone() }))
}

fn job_avg(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    // E_avg integrates E over the whole theta_i axis, which a scene does not restrict.
    let mut axes = sub_domain(avg_axes(preset), EPD_ALBEDO_AVG.cubic, options)?;
    axes.push(albedo_axes(preset).swap_remove(2));
    Ok(Box::new(AlbedoJob { axes, avg: true, context: options.context.clone() }))
}

/// Either table: one unit per p node; `axes` are (p, beta, theta_i), `avg` stores E_avg per (p, beta).
struct AlbedoJob {
    axes: Vec<Axis>,
    avg: bool,
    context: Option<Arc<BuildContext>>,
}

impl AlbedoJob {
    fn name(&self) -> &'static str {
        if self.avg {
            EPD_ALBEDO_AVG.name
        } else {
            EPD_ALBEDO.name
        }
    }

    fn stored_axes(&self) -> &[Axis] {
        &self.axes[..if self.avg { 2 } else { 3 }]
    }
}

/// 2 int E(mu) mu dmu of a column of E at the theta_i nodes, interpolated cubically in the
/// encoding as a runtime reads the table, E(acos MU_MIN) beyond as a runtime clamps.
fn average(theta: &Axis, column: &[f64]) -> f64 {
    let tail = column[column.len() - 1] * MU_MIN * MU_MIN;
    theta_average(theta, tail, |j, t| {
        let (s, w) = cubic_weights(j, t, column.len());
        (0..4).map(|k| w[k] * column[s + k]).sum()
    })
}

impl Job for AlbedoJob {
    fn units(&self) -> usize {
        self.axes[0].len()
    }

    fn unit_len(&self) -> usize {
        self.stored_axes()[1..].iter().map(Axis::len).product()
    }

    fn unit_name(&self) -> &'static str {
        "p node"
    }

    fn compute(&self, units: Units, progress: Progress) -> Part {
        let start = Instant::now();
        let bar = progress.bar(self.name(), units.count as u64);
        let slabs: Vec<Vec<f32>> = (0..units.count)
            .map(|j| {
                let cols = columns(&self.context, self.axes[0].nodes[units.get(j)], &self.axes[1].nodes, &self.axes[2]);
                bar.inc(1);
                if self.avg {
                    cols.iter().map(|c| average(&self.axes[2], c) as f32).collect()
                } else {
                    cols.iter().flat_map(|c| c.iter().map(|&e| e as f32)).collect()
                }
            })
            .collect();
        bar.finish_and_clear();
        let value = if self.avg { "e_avg" } else { "e" };
        Part {
            values: vec![(value.into(), slabs.concat())],
            compute_seconds: start.elapsed().as_secs_f64(),
            ..Part::default()
        }
    }

    fn finish(&self, whole: Part) -> Built {
        let axes = self.stored_axes().to_vec();
        let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
        let (name, data) = whole.values.into_iter().next().expect("one value");
        let values = ArrayD::from_shape_vec(IxDyn(&shape), data).expect("one entry per node");
        let start = Instant::now();
        let (accuracy, settings) = if self.avg { measure_avg(&axes, &values) } else { measure_albedo(&axes, &values) };
        let table = Table {
            name: self.name().into(),
            preset: Preset::Default.name().into(),
            axes,
            values: vec![(name, values)],
        };
        Built {
            table,
            accuracy,
            settings,
            compute_seconds: whole.compute_seconds,
            accuracy_seconds: start.elapsed().as_secs_f64(),
            stages: Value::Null,
            derived: Derived { interpolation: Interpolation::Cubic, ..Derived::default() },
        }
    }
}

/// `count` probes, fewer for a scene's sub-domain table (one per 16 nodes, at least 8).
fn probes(count: usize, nodes: usize) -> usize {
    count.min(nodes / 16).max(8)
}

/// (node, stored value) at about `count` nodes: `groups` nodes of the first axis (p) spread evenly
/// over it, ends included, and on each, nodes every `stride` over its slab of the other axes
/// (flat C order, from an offset that moves with the group); returns them with the stride.
fn sampled_nodes(axes: &[Axis], values: &ArrayD<f32>, groups: usize, count: usize) -> (Vec<(Vec<f64>, f64)>, usize) {
    let n0 = axes[0].len();
    let groups = groups.min(n0);
    let slab = values.len() / n0;
    let stride = (slab * groups / count.max(1)).max(1);
    let flat = values.as_slice().expect("C order");
    let nodes = (0..groups)
        .map(|g| if groups == 1 { 0 } else { g * (n0 - 1) / (groups - 1) })
        .flat_map(|i| {
            (g_offset(i, stride)..slab).step_by(stride).map(move |j| {
                let (mut rem, mut pt) = (j, vec![axes[0].nodes[i]; axes.len()]);
                for d in (1..axes.len()).rev() {
                    pt[d] = axes[d].nodes[rem % axes[d].len()];
                    rem /= axes[d].len();
                }
                (pt, flat[i * slab + j] as f64)
            })
        })
        .collect();
    (nodes, stride)
}

/// The first slab offset of group i: a different phase of the stride per group.
fn g_offset(i: usize, stride: usize) -> usize {
    (i * 7919) % stride
}

/// `eval(setup(p), point)` at every point, one `setup` per run of consecutive points with the same p.
fn grouped_reference<S: Sync>(
    points: &[Vec<f64>],
    setup: impl Fn(f64) -> S + Sync,
    eval: impl Fn(&S, &[f64]) -> f64 + Sync,
) -> Vec<f64> {
    let runs: Vec<&[Vec<f64>]> = points.chunk_by(|a, b| a[0] == b[0]).collect();
    runs.into_par_iter()
        .map(|run| {
            let s = setup(run[0][0]);
            run.par_iter().map(|pt| eval(&s, pt)).collect::<Vec<f64>>()
        })
        .collect::<Vec<_>>()
        .concat()
}

/// The cubic interpolation of `values` at `points`, as `twoscale lookup` reads the table.
fn interpolated(name: &str, axes: &[Axis], values: &ArrayD<f32>, points: &[Vec<f64>]) -> Vec<f64> {
    let lookup = Lookup::new(
        name.into(),
        axes.to_vec(),
        vec![("v".into(), values.clone())],
        vec![],
        vec![],
        Interpolation::Cubic,
    );
    points.iter().map(|pt| lookup.decode(pt).expect("probe inside the table")[0]).collect()
}

const PROBES_WHAT: &str = "cubic interpolation of the stored f32 values in encoded coordinates (as `twoscale lookup`) \
    against the reference, at random points in groups of 40 sharing p: the groups' p and each point's other coordinates \
    half uniform in the encoding of each axis, half at centres (in the encoding) of random cells";

/// Node error at about `nodes` nodes (on NODE_GROUPS p nodes) and interpolation error at `count`
/// random points (in groups of GROUP_SIZE sharing p) of `values` against `eval(setup(p), point)`
/// (both fewer for a scene's sub-domain, `probes`): the accuracy section.
#[allow(clippy::too_many_arguments)]
fn measure<S: Sync>(
    name: &str,
    axes: &[Axis],
    values: &ArrayD<f32>,
    (nodes, count): (usize, usize),
    node_what: &str,
    what: Value,
    setup: impl Fn(f64) -> S + Sync,
    eval: impl Fn(&S, &[f64]) -> f64 + Sync,
) -> Value {
    let (sampled, stride) = sampled_nodes(axes, values, NODE_GROUPS, probes(nodes, values.len()));
    let points: Vec<Vec<f64>> = sampled.iter().map(|(pt, _)| pt.clone()).collect();
    let reference = grouped_reference(&points, &setup, &eval);
    let samples: Vec<(Vec<f64>, f64, f64)> =
        sampled.into_iter().zip(reference).map(|((pt, v), r)| (pt, v, r)).collect();
    let mismatches = samples.iter().filter(|(_, v, r)| *v as f32 != *r as f32).count();
    let node = ErrorStats { f32_mismatches: Some(mismatches), ..ErrorStats::from_samples(&samples, None) };
    let count = probes(count, values.len());
    let points = grouped_points(axes, count.div_ceil(GROUP_SIZE), GROUP_SIZE.min(count), SEED);
    let got = interpolated(name, axes, values, &points);
    let reference = grouped_reference(&points, &setup, &eval);
    let samples: Vec<(Vec<f64>, f64, f64)> =
        points.into_iter().zip(got).zip(reference).map(|((pt, v), r)| (pt, v, r)).collect();
    let interp = ErrorStats::from_samples(&samples, None);
    let mut accuracy = AccuracyReport {
        axes,
        node_what,
        node_stride: stride,
        node: &node,
        interp_what: PROBES_WHAT,
        interp_seed: SEED,
        interp: &interp,
    }
    .to_json(json!({ "reference": what }));
    accuracy["target"] = json!({ "max_abs_after_interpolation": TARGET, "met": interp.max_abs <= TARGET });
    accuracy
}

fn measure_albedo(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    let node_what = format!(
        "stored f32 E against the reference at {NODE_GROUPS} p nodes spread evenly over the axis, every stride-th node of \
         each one's (beta, theta_i) slab (flat C order); includes the f32 rounding"
    );
    let eval =
        |curve: &LambdaCurve, pt: &[f64]| albedo_reference_with(pt[0], pt[1], pt[2], REFERENCE_TOL, |a| curve.at(a));
    let accuracy = measure(
        EPD_ALBEDO.name,
        axes,
        values,
        (NODES_MEASURED, PROBES),
        &node_what,
        json!(reference_text()),
        |p| LambdaCurve::new(p, REFERENCE_CURVE_NODES),
        eval,
    );
    (accuracy, settings())
}

fn measure_avg(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    // E_avg of the table's own rule, integrated adaptively in ln tan theta_i: what the cubic
    // interpolation along theta_i and across (p, beta) adds to the rule's error, which epd_albedo's
    // accuracy measures against the adaptive reference.
    let eval = |table: &LambdaTable, pt: &[f64]| {
        let e = |t: f64| albedo_column(table, pt[1], &[t])[0];
        let f = |x: f64| {
            let t = x.exp().atan();
            e(t) * (2.0 * t).sin() * t.sin() * t.cos()
        };
        let tail = e(MU_MIN.acos()) * MU_MIN * MU_MIN;
        tail + integrate(f, &[-12.0, -3.0, 0.0, 3.0, (1.0 / MU_MIN).ln()], REFERENCE_TOL, 1e-10).value
    };
    let node_what = "stored f32 E_avg (epd_albedo's E at its theta_i nodes, interpolated cubically and integrated by 8-point \
                     Gauss-Legendre per cell) against 2 int E sin theta cos theta dtheta of E by the same rule, by \
                     adaptive Gauss-Kronrod in ln tan theta_i over [-12, ln 1e6] (E(acos 1e-6) beyond, as a runtime clamps), at \
                     p nodes spread evenly, every stride-th beta node of each; the rule's own error is epd_albedo's node error";
    let what =
        "E_avg of the rule, as for the nodes: the error of interpolating E_avg and of integrating the interpolated E";
    let accuracy = measure(
        EPD_ALBEDO_AVG.name,
        axes,
        values,
        (AVG_NODES_MEASURED, AVG_PROBES),
        node_what,
        json!(what),
        LambdaTable::new,
        eval,
    );
    (accuracy, settings())
}

fn reference_text() -> String {
    format!(
        "E by nested adaptive Gauss-Kronrod (G7/K15) over (ln tan theta_h, phi) at relative tolerance {REFERENCE_TOL:e}, D from \
         h = (i + o)/|i + o|, Lambda(p, a) from {REFERENCE_CURVE_NODES} nodes uniform in ln a over [-50, 15] by epd_math::lambda, \
         4-point Lagrange between them (within 1e-9 of the quadrature; 0 below, a M1(p) - 1/2 above)"
    )
}

fn settings() -> Value {
    json!({
        "rule": rule_text(),
        "lambda": "Lambda(p, a) by epd_math::lambda at t = a^2 = 2^e (1 + k/32), k = 0..31 (32 cells per octave of t), from where \
                   Lambda reaches 1e-17 to t = 2^44, a cubic per cell in t (4-point Lagrange through the nearest nodes); 0 below, \
                   a M1(p) - 1/2 above",
        "probes": PROBES,
        "nodes_measured": NODES_MEASURED,
        "avg_probes": AVG_PROBES,
        "probe_group_size": GROUP_SIZE,
        "reference_tol": REFERENCE_TOL,
    })
}
