//! Stage `epd-g1`: the Smith shadowing table `epd_g1` (docs/maths.md section 2) and the
//! EPD normalisation `epd_norm` (docs/maths.md section 1).

use super::epd_math::{g1, g1_tol, norm, LAMBDA_REL_TOL};
use super::job::Job;
use super::nodewise::{Nodewise, Values};
use super::options::BuildOptions;
use super::preset::Preset;
use super::sub_domain::restrict;
use super::table_def::TableDef;
use crate::accuracy::measure;
use crate::numerics::quadrature;
use crate::numerics::tabulate::tabulate;
use crate::progress::Progress;
use anyhow::Result;
use ndarray::ArrayD;
use serde_json::{json, Value};
use twoscale_tables::axis::{Axis, AxisEncoding};

pub const EPD_G1: TableDef = TableDef {
    name: "epd_g1",
    stage: "epd-g1",
    definition: "docs/maths.md section 2: g1 = G1(p, a) = 1 / (1 + Lambda(p, a)), Smith shadowing of the EPD \
                 slope density (beta = 1), a = beta tan(theta)",
    axes: g1_axes,
    diffraction: false,
    cubic: false,
    job: job_g1,
    presets: &Preset::ALL,
};

pub const EPD_NORM: TableDef = TableDef {
    name: "epd_norm",
    stage: "epd-g1",
    definition: "docs/maths.md section 1: n = N(p) = p / (pi Gamma(1/p)), N(0) = 0",
    axes: norm_axes,
    diffraction: false,
    cubic: false,
    job: job_norm,
    presets: &Preset::ALL,
};

/// Reference tolerance for measuring node errors (the build uses LAMBDA_REL_TOL).
pub const REFERENCE_REL_TOL: f64 = 1e-14;
/// Random off-grid probes for the interpolation error.
const PROBES: usize = 40_000;

/// The default a axis: logarithmic between 1e-18 (below, 1 - G1 < 1e-7 for
/// every p >= 0.05) and 1e5 (above, G1 < 1e-4 and nearly linear in the
/// encoding), reaching 0 and +inf.
const A_ENCODING: AxisEncoding = AxisEncoding::BoundedLog { eps: 1e-18, delta: 1e-5 };
/// Default grid size, from measured 1-D interpolation errors: with nodes
/// uniform in 1/p the worst error along p is ~29 / n_p^2 (at p -> 0.05) and with
/// nodes uniform in A_ENCODING the worst along a is ~100 / n_a^2 (at p = 5,
/// a ~ 1.6, the near-disk kink); these sizes keep their sum below 9e-5.
const DEFAULT_NP: usize = 660;
const DEFAULT_NA: usize = 1900;

/// Axes (p, a) of `epd_g1`.
pub fn g1_axes(preset: Preset) -> Vec<Axis> {
    match preset {
        Preset::Paper => vec![
            Axis::new("p", (0..100).map(|i| 5.0 / (i as f64 + 1.0)).collect(), AxisEncoding::Reciprocal),
            Axis::new(
                "a",
                (0..1000)
                    .map(|j| if j == 999 { f64::INFINITY } else { 1.0 / (1000.0 / (j as f64 + 1.0)).ln().powi(20) })
                    .collect(),
                AxisEncoding::ExpNegPower { k: 20.0 },
            ),
        ],
        Preset::Default => default_axes(DEFAULT_NP, DEFAULT_NA),
    }
}

/// The default preset's (p, a) axes with `n_p` x `n_a` nodes (`twoscale bench` varies them).
pub fn default_axes(n_p: usize, n_a: usize) -> Vec<Axis> {
    vec![
        Axis::uniform("p", AxisEncoding::Reciprocal, 5.0, 0.05, n_p),
        Axis::uniform("a", A_ENCODING, 0.0, f64::INFINITY, n_a),
    ]
}

/// Default grid size (n_p, n_a).
pub const DEFAULT_SIZE: [usize; 2] = [DEFAULT_NP, DEFAULT_NA];

/// Axis p of `epd_norm`: the paper's 256 nodes p = 5k/256, or the p axis of `epd_g1`.
pub fn norm_axes(preset: Preset) -> Vec<Axis> {
    match preset {
        Preset::Paper => vec![Axis::new("p", (0..256).map(|k| 5.0 * k as f64 / 256.0).collect(), AxisEncoding::Linear)],
        Preset::Default => vec![g1_axes(preset).swap_remove(0)],
    }
}

/// G1 at every node of (p, a) axes, rounded to f32.
pub fn compute_g1(axes: &[Axis], progress: Progress) -> ArrayD<f32> {
    tabulate(axes, "epd_g1", progress, |pt| g1(pt[0], pt[1]))
}

fn job_g1(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let (axes, _) = restrict(g1_axes(preset), options)?;
    Ok(Box::new(Nodewise {
        table: EPD_G1.name,
        preset: preset.name(),
        axes,
        value: "g1",
        values: Values::Node(|pt| g1(pt[0], pt[1])),
        measure: measure_g1,
    }))
}

fn measure_g1(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    let reference = |pt: &[f64]| g1_tol(pt[0], pt[1], REFERENCE_REL_TOL);
    let accuracy = measure(
        axes,
        values,
        "stored f32 g1 against G1 from the same quadrature run at relative tolerance 1e-14, at every \
         stride-th node (flat C order); includes the f32 rounding",
        reference,
        |pt| g1(pt[0], pt[1]),
        PROBES,
        None,
        json!({
            "quadrature": "adaptive Gauss-Kronrod G7/K15 in y (rho = mu cosh y), |K15 - G7| summed below \
                           1e-10 relative; tests check Lambda against the p = 1 closed form, the a -> inf \
                           asymptote, the p -> inf disk limit and an independent 2-D quadrature",
        }),
    );
    let settings =
        json!({ "lambda_rel_tol": LAMBDA_REL_TOL, "reference_rel_tol": REFERENCE_REL_TOL, "probes": PROBES });
    (accuracy, settings)
}

/// N(p) from its definition, 1 / (2 pi int_0^inf exp(-rho^(2p)) rho drho), by
/// quadrature in v = ln(rho): independent of the Gamma-function closed form.
pub fn norm_by_quadrature(p: f64) -> f64 {
    if p == 0.0 {
        return 0.0;
    }
    // exp(-rho^(2p)) rho^2 in v; negligible below rho = 1e-12 and above rho^(2p) = 60 + 2/p.
    let v_hi = (60.0 + 2.0 / p).ln() / (2.0 * p);
    let v_lo = -12.0 * std::f64::consts::LN_10;
    let f = |v: f64| (2.0 * v - (2.0 * p * v).exp()).exp();
    let mut breaks = vec![v_lo, v_hi];
    if v_hi > 0.0 {
        breaks.insert(1, 0.0);
    }
    let integral = quadrature::integrate(f, &breaks, 1e-13, 0.0).value;
    1.0 / (2.0 * std::f64::consts::PI * integral)
}

fn job_norm(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let (axes, _) = restrict(norm_axes(preset), options)?;
    Ok(Box::new(Nodewise {
        table: EPD_NORM.name,
        preset: preset.name(),
        axes,
        value: "n",
        values: Values::Node(|pt| norm(pt[0])),
        measure: measure_norm,
    }))
}

fn measure_norm(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    let accuracy = measure(
        axes,
        values,
        "stored f32 N(p) (closed form with ln Gamma) against 1 / (2 pi int exp(-rho^(2p)) rho drho) by \
         adaptive quadrature, at every node",
        |pt| norm_by_quadrature(pt[0]),
        |pt| norm(pt[0]),
        10_000,
        None,
        json!({}),
    );
    (accuracy, json!({}))
}
