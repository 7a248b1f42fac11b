//! A material's EPD tables (docs/maths.md section 8): `epd_g1`, Smith's G1 over the
//! angle theta at the material's (p, beta), and `epd_sampling`, the quantile
//! of D(m) cos theta_m in theta_m.

use super::{built, quantile_accuracy, Material, QUANTILE_TARGET};
use crate::accuracy::random_points;
use crate::tables::epd_math::{epd_cdf_by_quadrature, epd_quantile, g1, g1_tol};
use crate::tables::Built;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::FRAC_PI_2;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::interp::interpolate;

/// Nodes of the theta axis: measured max error 1e-6 or less over the default domain's corners.
pub const G1_NODES: usize = 2049;
/// G1 is 1 to f64 below a = beta tan theta = A_LOW and below 1e-5 beyond A_HIGH (G1 ~ 1/(a M1(p))):
/// the encoding spends its nodes between them.
const A_LOW: f64 = 1e-6;
const A_HIGH: f64 = 1e6;
/// Nodes of the xi axis of epd_sampling (uniform in asin(sqrt(xi))).
pub const SAMPLING_NODES: usize = 4097;
pub const PROBES: usize = 2000;
const SEED: u64 = 0x6d61;

/// `epd_g1`: g1 over theta in [0, pi/2], encoded by ln((tan theta + eps)/(1 + delta tan theta))
/// with eps = A_LOW / beta, delta = beta / A_HIGH.
pub fn g1_table(m: &Material) -> Built {
    let start = Instant::now();
    let axis = Axis::uniform(
        "theta",
        AxisEncoding::BoundedLogTan { eps: A_LOW / m.beta, delta: m.beta / A_HIGH },
        0.0,
        FRAC_PI_2,
        G1_NODES,
    );
    let g: Vec<f32> = axis.nodes.par_iter().map(|&th| g1(m.p, m.beta * th.tan()) as f32).collect();
    let values = ArrayD::from_shape_vec(IxDyn(&[axis.len()]), g).expect("one per node");
    let compute_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let axes = vec![axis];
    let points = random_points(&axes, PROBES, SEED);
    let errors: Vec<f64> = points
        .par_iter()
        .map(|pt| {
            (interpolate(&axes, &values.view(), pt).expect("inside") - g1_tol(m.p, m.beta * pt[0].tan(), 1e-13)).abs()
        })
        .collect();
    let (max, worst) = errors.iter().enumerate().fold((0.0f64, 0), |b, (i, &e)| if e > b.0 { (e, i) } else { b });
    let accuracy = json!({
        "what": format!("absolute error of the lookup (linear in the encoded theta) at {PROBES} random theta (half uniform in \
                         the encoding, half at cell centres) against G1(p, beta tan theta) by the same Lambda quadrature \
                         at relative tolerance 1e-13; includes the f32 rounding"),
        "target": 1e-5,
        "max": max,
        "median": super::median(&errors),
        "worst_theta": points[worst][0],
    });
    let settings = json!({ "nodes": G1_NODES, "a_low": A_LOW, "a_high": A_HIGH });
    built(
        m,
        "epd_g1",
        axes,
        vec![("g1", values)],
        accuracy,
        settings,
        compute_seconds,
        start.elapsed().as_secs_f64(),
        Default::default(),
    )
}

/// `epd_sampling`: theta_m over xi in [0, 1] (encoded asin(sqrt(xi))), the quantile of D(m) cos theta_m.
pub fn sampling_table(m: &Material) -> Built {
    let start = Instant::now();
    let axis = Axis::uniform("xi", AxisEncoding::AsinSqrt, 0.0, 1.0, SAMPLING_NODES);
    let q: Vec<f32> = axis.nodes.par_iter().map(|&xi| epd_quantile(m.p, m.beta, xi) as f32).collect();
    let values = ArrayD::from_shape_vec(IxDyn(&[axis.len()]), q).expect("one per node");
    let compute_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let axes = vec![axis];
    let points = random_points(&axes, PROBES, SEED + 1);
    let errors: Vec<(f64, f64)> = points
        .par_iter()
        .map(|pt| {
            let theta = interpolate(&axes, &values.view(), pt).expect("inside");
            (pt[0], (epd_cdf_by_quadrature(m.p, m.beta, theta) - pt[0]).abs())
        })
        .collect();
    let accuracy = quantile_accuracy(
        &errors,
        "|F(theta(xi)) - xi| at random xi (half uniform in asin(sqrt(xi)), half at cell centres), theta(xi) the lookup, F the CDF \
         of D(m) cos theta_m by double-exponential quadrature of p / Gamma(1/p) exp(-y^p) over y in [0, tan^2 theta / beta^2] \
         (independent of the incomplete gamma the table is built with)",
    );
    let settings = json!({
        "nodes": SAMPLING_NODES,
        "target_density": "D(m) cos theta_m (docs/maths.md section 1): CDF P(1/p, (tan^2 theta_m / beta^2)^p), the regularised lower incomplete gamma",
        "sampled_density": super::SAMPLED_DENSITY_1D,
        "quantile_target": QUANTILE_TARGET,
    });
    built(
        m,
        "epd_sampling",
        axes,
        vec![("theta_m", values)],
        accuracy,
        settings,
        compute_seconds,
        start.elapsed().as_secs_f64(),
        Default::default(),
    )
}
