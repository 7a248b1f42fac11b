//! The directional albedo of the EPD microfacet lobe (docs/maths.md section 9), SPEC section 7's
//! specular part with A = 1 and F = 1:
//!     E(theta_i; p, beta) = int_{o_z > 0} D(h) G2(i, o) / (4 cos theta_i cos theta_o) cos theta_o do,
//! integrated over the half vector h (theta_h, phi): o = 2 (i.h) h - i, do = 4 (i.h) dh. With i in
//! the xz-plane, o_z > 0 exactly for phi < phi_max(theta_h), cos phi_max = -cot theta_i cot 2 theta_h
//! (no cut below theta_c = pi/4 - theta_i/2, nothing beyond theta_max = pi/4 + theta_i/2), and the
//! integrand is even in phi. theta_h is integrated in x = ln tan theta_h (the lobe's scales, from
//! beta to pi/2, are logarithmic). This module holds that geometry, the adaptive reference and E_avg's
//! integral; epd_albedo's rule is `epd_albedo_column`, and the per-material `albedo`
//! (material/albedo.rs) integrates the whole BRDF over the same geometry with `panel_breaks`.

use super::epd_math::{lambda, m1, norm};
use crate::numerics::legendre::gauss_legendre;
use crate::numerics::quadrature::integrate;
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_4;
use twoscale_tables::axis::{Axis, AxisEncoding};

/// The albedo tables end at mu = cos theta_i = MU_MIN (a runtime clamps beyond): epd_g1 resolves
/// beta tan theta up to 1e6, and below it E of heavy tails (p < 0.1) falls to 0 within mu ~ 1e-7.
pub const MU_MIN: f64 = 1e-6;

/// The half-vector panels (`Incidence::breaks`): PANEL in x = ln tan theta_h from ln(X_LOW beta) (what
/// lies below is < 1e-8 of D's mass), min(PANEL, 1/p) within EDGE of ln beta (D's edge), growing
/// geometrically beyond x = 2.
const X_LOW: f64 = 1e-4;
const PANEL: f64 = 0.5;
const EDGE: f64 = 1.5;

/// The directions of one incidence: i, cos phi_max's numerator and the breaks in theta_h.
pub struct Incidence {
    pub i: [f64; 3],
    cot_i: f64,
    theta_c: f64,
    pub theta_max: f64,
}

impl Incidence {
    pub fn new(mu: f64) -> Incidence {
        let theta_i = mu.acos();
        let sin_i = (1.0 - mu * mu).sqrt();
        Incidence {
            i: [sin_i, 0.0, mu],
            cot_i: mu / sin_i,
            theta_c: FRAC_PI_4 - 0.5 * theta_i,
            theta_max: FRAC_PI_4 + 0.5 * theta_i,
        }
    }

    /// phi_max at theta_h: o_z > 0 for phi < phi_max.
    pub fn phi_max(&self, theta_h: f64) -> f64 {
        (-self.cot_i / (2.0 * theta_h).tan()).clamp(-1.0, 1.0).acos()
    }

    /// o and the Jacobian 4 (i.h) of the half vector at (theta_h, phi); None below the surface.
    pub fn reflect(&self, theta_h: f64, phi: f64) -> Option<([f64; 3], f64)> {
        let (st, ct) = theta_h.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let h = [st * cp, st * sp, ct];
        let ih = self.i[0] * h[0] + self.i[2] * h[2];
        let o = [2.0 * ih * h[0] - self.i[0], 2.0 * ih * h[1], 2.0 * ih * h[2] - self.i[2]];
        (o[2] > 0.0 && ih > 0.0).then_some((o, 4.0 * ih))
    }

    /// The breaks in x = ln tan theta_h: `panel_breaks` to ln tan theta_max, with theta_c.
    pub fn breaks(&self, beta: f64, p: f64) -> Vec<f64> {
        let mut breaks = panel_breaks(beta, p, self.theta_max.tan().ln());
        let (lo, hi) = (breaks[0], breaks[breaks.len() - 1]);
        let xc = self.theta_c.tan().ln();
        if xc > lo && xc < hi {
            breaks.push(xc);
            breaks.sort_by(f64::total_cmp);
        }
        breaks
    }

    /// ln tan theta_c: below it no horizon cut (phi_max = pi).
    pub fn x_c(&self) -> f64 {
        self.theta_c.tan().ln()
    }
}

/// The half-vector panels in x = ln tan theta_h: from ln(X_LOW beta) by PANEL (min(PANEL, 1/p) near
/// ln beta) to 2, then doubling, to `hi`. The panels below any hi are those of a larger one, cut there.
pub fn panel_breaks(beta: f64, p: f64, hi: f64) -> Vec<f64> {
    let lo = (X_LOW * beta).ln();
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
    breaks
}

/// The rule text for manifests.
pub fn rule_text(nodes: usize, phi_nodes: usize) -> String {
    format!(
        "half vector: x = ln tan theta_h from ln({X_LOW:e} beta) to ln tan(pi/4 + theta_i/2) in panels of {PANEL} (min({PANEL}, 1/p) within \
         {EDGE} of ln beta, doubling beyond x = 2, a break at theta_h = pi/4 - theta_i/2) of {nodes} Gauss-Legendre nodes; phi in \
         [0, phi_max(theta_h)] (o_z > 0) by {phi_nodes}-node Gauss-Legendre, doubled by symmetry"
    )
}

/// int rho(o) cos theta_o do at mu by nested adaptive Gauss-Kronrod (`numerics::quadrature`) over
/// (x, phi) at relative tolerance `tol`, starting from coarser panels than the fixed rule's: the
/// albedo tables' accuracy reference.
pub fn adaptive(mu: f64, beta: f64, p: f64, tol: f64, rho: impl Fn([f64; 3]) -> f64) -> f64 {
    let inc = Incidence::new(mu);
    let outer = |x: f64| {
        let theta_h = x.exp().atan();
        let (st, ct) = theta_h.sin_cos();
        let inner = |phi: f64| inc.reflect(theta_h, phi).map_or(0.0, |(o, j)| rho(o) * j * o[2]);
        2.0 * st * st * ct * integrate(inner, &[0.0, inc.phi_max(theta_h)], tol, 1e-10).value
    };
    let mut breaks: Vec<f64> = inc.breaks(beta, p).into_iter().step_by(4).chain([inc.theta_max.tan().ln()]).collect();
    breaks.dedup();
    integrate(outer, &breaks, tol, 1e-9).value
}

/// int_0^theta_last E(theta) sin 2 theta dtheta (= 2 int E(mu) mu dmu) along a `bounded_log_tan`
/// axis, E in cell j at weight t given by `cell_value(j, t)`, added to `start`: 8-point
/// Gauss-Legendre per cell in the encoded coordinate, exact to f64 for a polynomial interpolant.
pub fn theta_average(theta: &Axis, start: f64, cell_value: impl Fn(usize, f64) -> f64) -> f64 {
    let (gx, gw) = gauss_legendre(8);
    let AxisEncoding::BoundedLogTan { eps, delta } = theta.encoding else { unreachable!("theta_i's encoding") };
    let e = theta.encoded();
    let mut sum = start;
    for j in 0..e.len() - 1 {
        let (c, h) = (0.5 * (e[j] + e[j + 1]), 0.5 * (e[j + 1] - e[j]));
        for (x, w) in gx.iter().zip(&gw) {
            // tan theta = (z - eps)/(1 - delta z), z = exp(e); dtheta/de = (dtan/de)/(1 + tan^2)
            let z = (c + h * x).exp();
            let tan = (z - eps) / (1.0 - delta * z);
            let dtheta = z * (1.0 - delta * eps) / (1.0 - delta * z).powi(2) / (1.0 + tan * tan);
            sum += h * w * cell_value(j, 0.5 * (x + 1.0)) * (2.0 * tan.atan()).sin() * dtheta;
        }
    }
    sum
}

/// Lambda(p, a) of one p on `n` nodes uniform in ln a over [LN_A_LO, LN_A_HI], 4-point Lagrange
/// between them; 0 below (Lambda < 1e-60 there for every p >= 0.05), the asymptote a M1(p) - 1/2
/// above: independent of `LambdaTable` (its coordinate, cells and interpolation), so that the
/// reference does not share the rule's Lambda. 0.10.0's rule read a 16,001-node curve; the
/// manifests' reference reads REFERENCE_CURVE_NODES.
pub struct LambdaCurve {
    pub p: f64,
    m1: f64,
    nodes: Vec<f64>,
}

const LN_A_LO: f64 = -50.0;
const LN_A_HI: f64 = 15.0;
/// Within 1e-9 of the quadrature (relative above Lambda = 1; test below), at half the cost
/// of 0.10.0's 16,001 nodes.
pub const REFERENCE_CURVE_NODES: usize = 8001;

impl LambdaCurve {
    pub fn new(p: f64, n: usize) -> LambdaCurve {
        let step = (LN_A_HI - LN_A_LO) / (n - 1) as f64;
        let nodes = (0..n).into_par_iter().map(|k| lambda(p, (LN_A_LO + step * k as f64).exp())).collect();
        LambdaCurve { p, m1: m1(p), nodes }
    }

    pub fn at(&self, a: f64) -> f64 {
        if a <= 0.0 {
            return 0.0;
        }
        let x = a.ln();
        if x >= LN_A_HI {
            return a * self.m1 - 0.5;
        }
        if x <= LN_A_LO {
            return 0.0;
        }
        let n = self.nodes.len();
        let f = (x - LN_A_LO) / (LN_A_HI - LN_A_LO) * (n - 1) as f64;
        let i = (f as usize).min(n - 2);
        let (s, w) = twoscale_tables::interp::cubic_weights(i, f - i as f64, n);
        (0..4).map(|k| w[k] * self.nodes[s + k]).sum()
    }
}

/// E(theta_i; p, beta) by `adaptive` at relative tolerance `tol`, with D from h = (i + o)/|i + o|
/// and Lambda by its own quadrature (`epd_math::lambda`) at every direction: the reference of the
/// rule (`twoscale bench --table epd_albedo`, tests).
pub fn albedo_reference(p: f64, beta: f64, theta_i: f64, tol: f64) -> f64 {
    albedo_reference_with(p, beta, theta_i, tol, |a| lambda(p, a))
}

/// `albedo_reference` with Lambda(p, a) from `lambda`: with a `LambdaCurve` (within 1e-9 of the
/// quadrature, test below) it costs ~100 times less, the reference of the tables' manifests.
pub fn albedo_reference_with(p: f64, beta: f64, theta_i: f64, tol: f64, lambda: impl Fn(f64) -> f64) -> f64 {
    let (sin_i, mu) = theta_i.sin_cos();
    let n = norm(p) / (beta * beta);
    let lambda_i = lambda(beta * sin_i / mu);
    adaptive(mu, beta, p, tol, |o| {
        let h = [sin_i + o[0], o[1], mu + o[2]];
        let tan2_h = (h[0] * h[0] + h[1] * h[1]) / (h[2] * h[2]);
        let cos2_h = 1.0 / (1.0 + tan2_h);
        let d = n * (-(tan2_h / (beta * beta)).powf(p)).exp() / (cos2_h * cos2_h);
        let g2 = 1.0 / (1.0 + lambda_i + lambda(beta * o[0].hypot(o[1]) / o[2]));
        d * g2 / (4.0 * mu * o[2])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::sampling::SplitMix64;

    /// The reference's curve against the quadrature at random a, log-uniform over its range and beyond.
    #[test]
    fn lambda_curve_against_the_quadrature() {
        let mut rng = SplitMix64::new(11);
        for p in [0.05, 0.3, 1.0, 5.0] {
            let curve = LambdaCurve::new(p, REFERENCE_CURVE_NODES);
            let worst = (0..3000)
                .map(|_| (-55.0 + 75.0 * rng.uniform()).exp())
                .map(|a| (curve.at(a) - lambda(p, a)).abs() / lambda(p, a).max(1.0))
                .fold(0.0f64, f64::max);
            assert!(worst < 1e-9, "p = {p}: {worst:e}");
        }
    }
}
