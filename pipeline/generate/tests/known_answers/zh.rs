//! The convolution of docs/maths.md section 4 against known answers: the Funk-Hecke
//! identity (zonal harmonics = direct integral) and spot values from an
//! independent quadrature.

use crate::de_split;
use std::f64::consts::{FRAC_PI_2, PI};
use twoscale_generate::tables::zh_math::{
    coefficients, d_lobe, exact_convolution, s_lobe, samples, synthesis_matrix, ThetaRule,
};
use twoscale_tables::lobe::LobeParams;

/// C_L at the fit samples, for one (u, c, beta, p).
fn c_l(u: f64, c: f64, p: f64, beta: f64, degree: usize) -> Vec<f64> {
    let rule = ThetaRule::standard(degree);
    let w = rule.weighted_legendre(degree);
    let f = coefficients(&rule, &w, &[|s2: f64, c2: f64| s_lobe(s2, c2, u, c)]);
    let g = coefficients(&rule, &w, &[|s2: f64, c2: f64| d_lobe(s2, c2, p, beta)]);
    (&f.row(0) * &g.row(0)).dot(&synthesis_matrix(degree)).to_vec()
}

fn theta(k: usize) -> f64 {
    samples()[k].0.sqrt().asin()
}

#[test]
fn funk_hecke_identity_for_smooth_lobes() {
    let (u, c, beta, p) = (0.5, 2.0, 0.3, 1.0);
    let cl = c_l(u, c, p, beta, 100);
    let max_c = cl.iter().fold(0.0f64, |m, x| m.max(*x));
    for k in (0..1000).step_by(37).chain([999]) {
        let exact = exact_convolution(theta(k), &LobeParams { u, c, p, beta }, 1e-11);
        assert!((cl[k] - exact).abs() < 1e-8 * max_c, "k={k}: C_L {} vs C {exact}", cl[k]);
    }
}

/// C(theta_h) by nested double-exponential quadrature over m = (theta_m, phi)
/// around n (the `quadrature` crate; no code shared with the pipeline's).
fn independent_c(theta_h: f64, u: f64, c: f64, p: f64, beta: f64) -> f64 {
    let (sh, ch) = theta_h.sin_cos();
    let outer = |tm: f64| {
        let (sm, cm) = tm.sin_cos();
        let d = (-((sm / cm / beta).powi(2)).powf(p)).exp() / cm.powi(4);
        let inner = |phi: f64| {
            let t = ch * cm + sh * sm * phi.cos();
            if t <= 0.0 {
                0.0
            } else {
                (1.0 + 4.0 * u * u * (1.0 - t * t)).powf(-(c + 1.0) / 2.0) * t * t
            }
        };
        d * sm * 2.0 * de_split(&inner, 0.0, PI, PI / 8.0, 1.0)
    };
    de_split(&outer, 0.0, FRAC_PI_2 - 1e-9, 0.05, 1.0)
}

#[test]
fn spot_values_from_an_independent_quadrature() {
    // u = 0 (S = t^2), and p = 1 (Beckmann D) with a moderate u.
    for &(u, c, beta, p) in &[(0.0, 2.0, 0.2, 0.7), (0.0, 1.5, 0.4, 3.0), (1.5, 2.5, 0.25, 1.0), (0.7, 1.2, 0.35, 1.0)]
    {
        for &th in &[0.0, 0.3, 0.8, 1.3] {
            let reference = independent_c(th, u, c, p, beta);
            let exact = exact_convolution(th, &LobeParams { u, c, p, beta }, 1e-11);
            assert!((exact / reference - 1.0).abs() < 1e-7, "u={u} p={p} theta={th}: direct {exact} vs DE {reference}");
        }
        let cl = c_l(u, c, p, beta, 200);
        for k in [999, 800, 400, 100] {
            let reference = independent_c(theta(k), u, c, p, beta);
            let max_c = cl.iter().fold(0.0f64, |m, x| m.max(*x));
            assert!((cl[k] - reference).abs() < 1e-7 * max_c, "u={u} p={p} k={k}: C_L {} vs DE {reference}", cl[k]);
        }
    }
}

#[test]
fn coefficients_converge_for_the_sharpest_lobes() {
    // The sharpest lobes of the default domain, against a refined rule.
    let degree = 400;
    let (a, b) = (ThetaRule::standard(degree), ThetaRule::refined(degree));
    let lobes_s = [|s2: f64, c2: f64| s_lobe(s2, c2, 100.0, 1.02)];
    let lobes_d = [|s2: f64, c2: f64| d_lobe(s2, c2, 5.0, 0.005), |s2: f64, c2: f64| d_lobe(s2, c2, 0.2, 0.5)];
    for (x, y) in [
        (
            coefficients(&a, &a.weighted_legendre(degree), &lobes_s),
            coefficients(&b, &b.weighted_legendre(degree), &lobes_s),
        ),
        (
            coefficients(&a, &a.weighted_legendre(degree), &lobes_d),
            coefficients(&b, &b.weighted_legendre(degree), &lobes_d),
        ),
    ] {
        for (rx, ry) in x.rows().into_iter().zip(y.rows()) {
            let scale = rx.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = rx.iter().zip(ry.iter()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            assert!(diff <= 1e-12 * scale, "relative change {:e}", diff / scale);
        }
    }
}
