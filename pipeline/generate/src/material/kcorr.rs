//! A material's `kcorr_renorm` (docs/maths.md section 8): R over (s = sin theta_i,
//! B = b / lambda in [b / lambda_max, b / lambda_min]) at its c.

use super::{built, Material};
use crate::accuracy::random_points;
use crate::tables::kcorr_math::{renorm, renorm_tol};
use crate::tables::Built;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::derived::{Derived, EncodedValue, ValueEncoding};
use twoscale_tables::interp::interpolate;

/// Nodes along s, encoded by the log of the gap to grazing incidence (R
/// changes within about 1/B of s = 1), and along B (ln B) per unit of ln(B_max / B_min).
pub const S_NODES: usize = 1025;
pub const B_NODES_PER_LN: f64 = 48.0;
pub const PROBES: usize = 2000;
pub const TARGET: f64 = 1e-4;
const SEED: u64 = 0x6b63;

/// The B axis: [b / lambda_max, b / lambda_min], widened by 1e-6 either side
/// when the material has one wavelength (an axis needs two distinct nodes).
pub fn b_axis(m: &Material) -> Axis {
    let (lo, hi) = m.b_over_lambda();
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo * (1.0 - 1e-6), hi * (1.0 + 1e-6)) };
    let n = ((hi / lo).ln() * B_NODES_PER_LN).ceil().max(8.0) as usize + 1;
    Axis::uniform("b_over_lambda", AxisEncoding::Log, lo, hi, n)
}

pub fn table(m: &Material) -> Built {
    let start = Instant::now();
    let c = m.c.expect("a diffracting material");
    // eps: the gap to grazing incidence the encoding resolves, well inside 1/B_max.
    let eps = (0.01 / m.b_over_lambda().1.powi(2)).min(1e-4);
    let axes = vec![Axis::uniform("s", AxisEncoding::LogGap { end: 1.0, eps }, 0.0, 1.0, S_NODES), b_axis(m)];
    let (ns, nb) = (axes[0].len(), axes[1].len());
    // Stored as ln R: R ~ (c - 1) B^2 / 2 at small B is then linear in the encoded ln B.
    let r: Vec<f32> = (0..ns * nb)
        .into_par_iter()
        .map(|k| renorm(axes[0].nodes[k / nb], axes[1].nodes[k % nb], c).ln() as f32)
        .collect();
    let values = ArrayD::from_shape_vec(IxDyn(&[ns, nb]), r).expect("one per node");
    let compute_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let points = random_points(&axes, PROBES, SEED);
    let errors: Vec<f64> = points
        .par_iter()
        .map(|pt| {
            let exact = renorm_tol(pt[0], pt[1], c, 1e-14);
            (interpolate(&axes, &values.view(), pt).expect("inside").exp() - exact).abs() / exact
        })
        .collect();
    let (max, worst) = errors.iter().enumerate().fold((0.0f64, 0), |b, (i, &e)| if e > b.0 { (e, i) } else { b });
    let accuracy = json!({
        "what": format!("relative error of the lookup (bilinear in ln R over the encoded s and B, then exp) at {PROBES} random (s, B) (half \
                         uniform in the encodings, half at cell centres) against R by the same quadrature at relative \
                         tolerance 1e-14; includes the f32 rounding"),
        "target": TARGET,
        "max": max,
        "median": super::median(&errors),
        "worst": { "s": points[worst][0], "b_over_lambda": points[worst][1] },
    });
    let settings = json!({ "s_nodes": ns, "b_nodes": nb, "log_gap_eps": eps });
    let derived = Derived {
        axes: vec![],
        values: vec![EncodedValue {
            value: "r".into(),
            encoding: ValueEncoding::Ln,
            control_variates: vec![],
            formula: "r = exp(stored): the stored value is ln R, interpolated bilinearly".into(),
        }],
        ..Derived::default()
    };
    built(
        m,
        "kcorr_renorm",
        axes,
        vec![("r", values)],
        accuracy,
        settings,
        compute_seconds,
        start.elapsed().as_secs_f64(),
        derived,
    )
}
