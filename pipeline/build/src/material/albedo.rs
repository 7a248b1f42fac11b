//! A material's `albedo` (docs/maths.md section 9): the directional albedo with
//! F = 1 of the whole single-scattering BRDF a runtime evaluates from the material's own tables
//! (`twoscale_tables::brdf`, docs/runtimes.md "eval"),
//!     E(mu, lambda) = int_{o_z > 0} rho(i, o) cos theta_o do,   mu = cos theta_i,
//! tabulated over theta_i (epd_g1's encoding: both normal and grazing incidence resolved), and
//! E_avg(lambda) = 2 int_0^1 E(mu) mu dmu of the table's own interpolant (the value `e_avg`,
//! stored at every theta_i node: the contract has one set of axes per table), so that a
//! compensation lobe (1 - E(i)) (1 - E(o)) / (pi (1 - E_avg)) restores 1 - E(i) (to f32 rounding).
//!
//! E is integrated over the half vector h (theta_h, phi): o = 2 (i.h) h - i, do = 4 (i.h) dh.
//! With i in the xz-plane, o_z > 0 exactly for phi < phi_max(theta_h), cos phi_max =
//! -cot theta_i cot 2 theta_h (no cut below theta_c = pi/4 - theta_i/2, nothing beyond
//! theta_max = pi/4 + theta_i/2), and rho is even in phi: E = 2 int dtheta_h int_0^phi_max dphi.
//! theta_h is integrated in x = ln tan theta_h (the lobes' scales, from beta to pi/2, are
//! logarithmic), composite Gauss-Legendre with breaks at theta_c; phi by Gauss-Legendre on
//! [0, phi_max]. The wavelength-free factors (G2, D, theta_h, cos_d) are shared by every lambda.

use super::{built, median, Material};
use crate::accuracy::random_points;
use crate::numerics::legendre::{composite_rule, gauss_legendre};
use crate::numerics::quadrature::integrate;
use crate::tables::Built;
use anyhow::Result;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::FRAC_PI_4;
use std::path::Path;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::brdf::MaterialBrdf;
use twoscale_tables::interp::interpolate;

/// Nodes along theta_i in [0, acos(MU_MIN)], uniform in epd_g1's encoding bounded_log_tan,
/// e = ln((tan theta_i + EPS)/(1 + delta tan theta_i)), delta = DELTA_BETA beta: logarithmic in
/// theta_i near normal incidence (heavy tails, p < 1/2, give E a cusp ~ theta_i^(2p) there) and
/// in mu = cos theta_i ~ cot theta_i near grazing incidence (E changes over mu ~ beta).
pub const THETA_NODES: usize = 1025;
pub const EPS: f64 = 1e-3;
pub const DELTA_BETA: f64 = 0.01;
/// epd_g1 resolves beta tan theta up to 1e6: below mu = 1e-6 the tables' BRDF is beyond it (a runtime clamps).
pub const MU_MIN: f64 = 1e-6;
/// Nodes along lambda (ln lambda) per unit of ln(lambda_max / lambda_min), at least 9.
pub const LAMBDA_NODES_PER_LN: f64 = 48.0;
/// The half-vector rule: panels of PANEL in x = ln tan theta_h from ln(X_LOW beta) (what lies below
/// is < 1e-8 of D's mass), of min(PANEL, 1/p) within EDGE of ln beta (D's edge), growing
/// geometrically beyond x = 2; NODES per panel; PHI_NODES in phi.
const X_LOW: f64 = 1e-4;
const PANEL: f64 = 0.5;
const EDGE: f64 = 1.5;
const NODES: usize = 6;
const PHI_NODES: usize = 12;
pub const TARGET: f64 = 1e-4;
pub const PROBES: usize = 512;
const REFERENCE_TOL: f64 = 1e-6;
const SEED: u64 = 0x616c;

/// The directions of one incidence: i, cos phi_max's numerator and the breaks in theta_h.
struct Incidence {
    i: [f64; 3],
    cot_i: f64,
    theta_c: f64,
    theta_max: f64,
}

impl Incidence {
    fn new(mu: f64) -> Incidence {
        let theta_i = mu.acos();
        let sin_i = (1.0 - mu * mu).sqrt();
        Incidence { i: [sin_i, 0.0, mu], cot_i: mu / sin_i, theta_c: FRAC_PI_4 - 0.5 * theta_i, theta_max: FRAC_PI_4 + 0.5 * theta_i }
    }

    /// phi_max at theta_h: o_z > 0 for phi < phi_max.
    fn phi_max(&self, theta_h: f64) -> f64 {
        (-self.cot_i / (2.0 * theta_h).tan()).clamp(-1.0, 1.0).acos()
    }

    /// o and the Jacobian 4 (i.h) of the half vector at (theta_h, phi); None below the surface.
    fn reflect(&self, theta_h: f64, phi: f64) -> Option<([f64; 3], f64)> {
        let (st, ct) = theta_h.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let h = [st * cp, st * sp, ct];
        let ih = self.i[0] * h[0] + self.i[2] * h[2];
        let o = [2.0 * ih * h[0] - self.i[0], 2.0 * ih * h[1], 2.0 * ih * h[2] - self.i[2]];
        (o[2] > 0.0 && ih > 0.0).then_some((o, 4.0 * ih))
    }

    /// The breaks in x = ln tan theta_h: from ln(X_LOW beta) by PANEL (min(PANEL, 1/p) near ln beta) to 2, then doubling, to theta_max, with theta_c.
    fn breaks(&self, beta: f64, p: f64) -> Vec<f64> {
        let (lo, hi) = ((X_LOW * beta).ln(), self.theta_max.tan().ln());
        let mut breaks = vec![lo];
        let (mut x, mut grow) = (lo, 1.0);
        while x < hi {
            // D's edge, exp(-e^(2p (x - ln beta))), within EDGE of ln beta: panels of at most 1/p there.
            let step = if (x - beta.ln()).abs() < EDGE { PANEL.min(1.0 / p) } else { PANEL * grow };
            x += step;
            if x < hi {
                breaks.push(x);
            }
            if x > 2.0 {
                grow *= 2.0;
            }
        }
        breaks.push(hi);
        let xc = self.theta_c.tan().ln();
        if xc > lo && xc < hi {
            breaks.push(xc);
            breaks.sort_by(f64::total_cmp);
        }
        breaks
    }
}

/// E(mu, lambda) at each of `lambdas` by the fixed half-vector rule.
pub fn albedo(brdf: &MaterialBrdf, mu: f64, lambdas: &[f64]) -> Vec<f64> {
    let inc = Incidence::new(mu);
    let (xs, xw) = composite_rule(&inc.breaks(brdf.beta, brdf.p), NODES);
    let (px, pw) = gauss_legendre(PHI_NODES);
    // Per lambda: B, K's factor over R (R depends on theta_i and B only).
    let per_lambda: Vec<(f64, f64, f64)> = lambdas
        .iter()
        .map(|&l| {
            let bb = brdf.b / l;
            let k = if brdf.has_diffraction() { brdf.k_scale(bb) * (-brdf.ln_r(inc.i[0], bb)).exp() } else { 0.0 };
            (l, bb, k)
        })
        .collect();
    let mut e = vec![0.0; lambdas.len()];
    for (&x, &wx) in xs.iter().zip(&xw) {
        let theta_h = x.exp().atan();
        let phi_max = inc.phi_max(theta_h);
        // dtheta_h = sin cos dx; dh = sin theta_h dtheta_h dphi; 2 for phi in [-phi_max, phi_max].
        let (st, ct) = theta_h.sin_cos();
        let w_theta = 2.0 * wx * st * ct * st * 0.5 * phi_max;
        for (&t, &wt) in px.iter().zip(&pw) {
            let phi = 0.5 * phi_max * (t + 1.0);
            let Some((o, jacobian)) = inc.reflect(theta_h, phi) else { continue };
            let Some(pair) = brdf.pair(inc.i, o) else { continue };
            let w = w_theta * wt * jacobian * o[2];
            for (sum, &(lambda, bb, k)) in e.iter_mut().zip(&per_lambda) {
                let rho = if brdf.has_diffraction() {
                    let a = brdf.coherent(pair.cos_d, lambda);
                    a * pair.specular + (1.0 - a) * pair.g2 * k * brdf.ln_c(bb * pair.cos_d, pair.theta_h).exp()
                } else {
                    pair.specular
                };
                *sum += w * rho;
            }
        }
    }
    e
}

/// The same E by nested adaptive Gauss-Kronrod (`numerics::quadrature`) over (x, phi) at
/// relative tolerance `tol`, for one lambda: the accuracy reference.
pub fn albedo_adaptive(brdf: &MaterialBrdf, mu: f64, lambda: f64, tol: f64) -> f64 {
    let inc = Incidence::new(mu);
    let rho = |o: [f64; 3]| {
        let [s, d] = brdf.eval_parts(inc.i, o, lambda);
        s + d
    };
    let outer = |x: f64| {
        let theta_h = x.exp().atan();
        let (st, ct) = theta_h.sin_cos();
        let inner = |phi: f64| inc.reflect(theta_h, phi).map_or(0.0, |(o, j)| rho(o) * j * o[2]);
        2.0 * st * st * ct * integrate(inner, &[0.0, inc.phi_max(theta_h)], tol, 1e-10).value
    };
    // Coarser initial panels than the fixed rule's, adaptive from there.
    let mut breaks: Vec<f64> = inc.breaks(brdf.beta, brdf.p).into_iter().step_by(4).chain([inc.theta_max.tan().ln()]).collect();
    breaks.dedup();
    integrate(outer, &breaks, tol, 1e-9).value
}

/// The axes: theta_i (and lambda when the material diffracts).
pub fn axes(m: &Material) -> Vec<Axis> {
    let theta = Axis::uniform("theta_i", AxisEncoding::BoundedLogTan { eps: EPS, delta: DELTA_BETA * m.beta }, 0.0, MU_MIN.acos(), THETA_NODES);
    match m.wavelengths {
        Some((lo, hi)) if m.has_diffraction() => {
            // One wavelength: widened 1e-6 either side (an axis needs two distinct nodes).
            let (lo, hi) = if hi > lo { (lo, hi) } else { (lo * (1.0 - 1e-6), hi * (1.0 + 1e-6)) };
            let n = ((hi / lo).ln() * LAMBDA_NODES_PER_LN).ceil().max(8.0) as usize + 1;
            vec![theta, Axis::uniform("lambda", AxisEncoding::Log, lo, hi, n)]
        }
        _ => vec![theta],
    }
}

/// 2 int_0^1 E(mu) mu dmu = int E sin 2 theta dtheta of the stored E of one lambda column (linear
/// in the encoded theta between nodes, E(acos MU_MIN) beyond as a runtime clamps): 8-point
/// Gauss-Legendre per cell, exact to f64 for that interpolant.
fn average(theta: &Axis, column: &[f32]) -> f64 {
    let (gx, gw) = gauss_legendre(8);
    let AxisEncoding::BoundedLogTan { eps, delta } = theta.encoding else { unreachable!("theta_i's encoding") };
    let e = theta.encoded();
    let n = e.len();
    let mut sum = column[n - 1] as f64 * MU_MIN * MU_MIN;
    for j in 0..n - 1 {
        let (c, h) = (0.5 * (e[j] + e[j + 1]), 0.5 * (e[j + 1] - e[j]));
        for (x, w) in gx.iter().zip(&gw) {
            let t = 0.5 * (x + 1.0);
            // tan theta = (z - eps)/(1 - delta z), z = exp(e); dtheta/de = (dt/de)/(1 + t^2)
            let z = (c + h * x).exp();
            let tan = (z - eps) / (1.0 - delta * z);
            let dtheta = z * (1.0 - delta * eps) / (1.0 - delta * z).powi(2) / (1.0 + tan * tan);
            let value = (1.0 - t) * column[j] as f64 + t * column[j + 1] as f64;
            sum += h * w * value * (2.0 * tan.atan()).sin() * dtheta;
        }
    }
    sum
}

/// `albedo` of the material whose other tables are in `dir`.
pub fn table(m: &Material, dir: &Path) -> Result<Built> {
    let start = Instant::now();
    let brdf = MaterialBrdf::open(dir)?;
    let axes = axes(m);
    let lambdas: Vec<f64> = axes.get(1).map_or(vec![1.0], |a| a.nodes.clone());
    let rows: Vec<Vec<f64>> = axes[0].nodes.par_iter().map(|&theta| albedo(&brdf, theta.cos(), &lambdas)).collect();
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let e: Vec<f32> = rows.iter().flatten().map(|&e| e as f32).collect();
    // E_avg per lambda, from the stored column; stored at every mu node (it does not depend on mu).
    let nl = lambdas.len();
    let avg: Vec<f32> = (0..nl).map(|k| average(&axes[0], &e.iter().skip(k).step_by(nl).copied().collect::<Vec<_>>()) as f32).collect();
    let e_avg: Vec<f32> = (0..e.len()).map(|j| avg[j % nl]).collect();
    let values = ArrayD::from_shape_vec(IxDyn(&shape), e).expect("one per node");
    let e_avg = ArrayD::from_shape_vec(IxDyn(&shape), e_avg).expect("one per node");
    let compute_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let points = random_points(&axes, PROBES, SEED);
    let errors: Vec<f64> = points
        .par_iter()
        .map(|pt| {
            let lambda = pt.get(1).copied().unwrap_or(1.0);
            (interpolate(&axes, &values.view(), pt).expect("inside") - albedo_adaptive(&brdf, pt[0].cos(), lambda, REFERENCE_TOL)).abs()
        })
        .collect();
    let (max, worst) = errors.iter().enumerate().fold((0.0f64, 0), |b, (i, &e)| if e > b.0 { (e, i) } else { b });
    let coordinates = |pt: &[f64]| axes.iter().zip(pt).map(|(a, x)| (a.name.clone(), json!(x))).collect::<serde_json::Map<_, _>>();
    let accuracy = json!({
        "what": format!("e: absolute error of the lookup (linear in the encoded theta_i{}) at {PROBES} random points (half uniform in \
                         the encodings, half at cell centres) against E by nested adaptive Gauss-Kronrod (7-15) over (ln tan theta_h, \
                         phi) at relative tolerance {REFERENCE_TOL:e}, of the same BRDF (the material's tables, docs/runtimes.md eval); \
                         includes the f32 rounding. e_avg: 2 int_0^1 e(mu) mu dmu of the stored e (its interpolant, clamped beyond \
                         acos(mu_min)) by 8-point Gauss-Legendre per cell, exact to f64 for that interpolant",
                        if nl > 1 { " and lambda" } else { "" }),
        "probes": PROBES,
        "target": TARGET,
        "max": max,
        "median": median(&errors),
        "worst": coordinates(&points[worst]),
    });
    let settings = json!({
        "theta_nodes": THETA_NODES, "mu_min": MU_MIN,
        "lambda_nodes_per_ln": m.has_diffraction().then_some(LAMBDA_NODES_PER_LN),
        "rule": format!("half vector: x = ln tan theta_h from ln({X_LOW:e} beta) to ln tan(pi/4 + theta_i/2) in panels of {PANEL} (min({PANEL}, 1/p) within \
                         {EDGE} of ln beta, doubling beyond x = 2, a break at theta_h = pi/4 - theta_i/2) of {NODES} Gauss-Legendre nodes; phi in [0, phi_max(theta_h)] (o_z > 0) \
                         by {PHI_NODES}-node Gauss-Legendre, doubled by symmetry"),
        "brdf": "docs/runtimes.md eval with F = 1, lobe exact: the material's epd_g1, kcorr_renorm and zh_lobe read by interpolation",
    });
    let accuracy_seconds = start.elapsed().as_secs_f64();
    Ok(built(m, "albedo", axes, vec![("e", values), ("e_avg", e_avg)], accuracy, settings, compute_seconds, accuracy_seconds, Default::default()))
}
