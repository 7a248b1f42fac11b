//! Least-squares fit of a K-correlation lobe to a convolved lobe (docs/maths.md section 4):
//!
//!   plain:  C(theta) ~ s (1 + 4 g^2 sin^2 theta)^(-(c+1)/2)
//!   cos:    C(theta) ~ s (1 + 4 g^2 sin^2 theta)^(-(c+1)/2) cos^2 theta
//!
//! by damped Newton steps (Levenberg-Marquardt damping on the full Hessian)
//! with analytic derivatives. The model depends on g
//! through gamma = g^2 only, so the fit runs in (s, gamma) with the bounds
//! s, gamma >= 0: there the bound is an ordinary one (the derivative in gamma
//! does not vanish on it, as it does in g), steps are projected onto it, and
//! convergence is a small projected gradient (KKT).

use crate::numerics::vector_math::{exp, ln};

/// Fit result; residuals are relative to the data (L2 norm and max).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub s: f64,
    pub g: f64,
    pub converged: bool,
    pub iterations: usize,
    /// Passes over the samples (each one ln and one exp per sample).
    pub evaluations: usize,
    pub rel_l2: f64,
    pub rel_max: f64,
}

/// Valleys where s and g are strongly correlated can take a few hundred steps.
const MAX_ITERATIONS: usize = 1000;

/// B = w q^-a and k = 4 sin^2 / q: the part with ln and exp.
#[inline(always)]
fn base(gamma: f64, sin2: f64, weight: f64, a: f64) -> (f64, f64) {
    let q = 1.0 + 4.0 * gamma * sin2;
    (exp(-a * ln(q)) * weight, 4.0 * sin2 / q)
}

/// Model value m = s B with B = w q^-a, q = 1 + 4 gamma sin^2, k = 4 sin^2 / q, and
/// the terms of the derivatives Newton needs: dm/ds = B, dm/dgamma = s E with
/// E = -a B k, d2m/ds dgamma = E, d2m/dgamma2 = s a (a + 1) B k^2; returns
/// (m, dm/ds, E, d2m/dgamma2 / s).
#[inline(always)]
fn terms(s: f64, a: f64, b: f64, k: f64) -> (f64, f64, f64, f64) {
    (s * b, b, -a * b * k, (a + 1.0) * a * b * k * k)
}

/// Cost (sum of squared residuals), the Gauss-Newton sums J^T J and J^T r,
/// the second-order terms sum r d2m, and the largest |residual|, in one pass
/// over the samples (one ln and one exp per sample: the fits' whole cost).
#[derive(Clone, Copy)]
struct Eval {
    cost: f64,
    jss: f64,
    jsg: f64,
    jgg: f64,
    rs: f64,
    rg: f64,
    /// sum r d2m/ds dgamma and sum r d2m/dgamma2.
    hsg: f64,
    hgg: f64,
    max_res: f64,
}

/// B and k (see `base`) for a chunk of samples.
#[inline(always)]
fn fill_bases_generic(gamma: f64, a: f64, x: &[f64], w: &[f64], bs: &mut [f64], ks: &mut [f64]) {
    for (((b, k), &x), &w) in bs.iter_mut().zip(ks.iter_mut()).zip(x).zip(w) {
        (*b, *k) = base(gamma, x, w, a);
    }
}

/// The same loop compiled for AVX2 (4 lanes instead of SSE2's 2). Every lane
/// does the same IEEE operations in the same order (no FMA contraction), so
/// the results are bit-identical to the SSE2 and scalar versions.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn fill_bases_avx2(gamma: f64, a: f64, x: &[f64], w: &[f64], bs: &mut [f64], ks: &mut [f64]) {
    fill_bases_generic(gamma, a, x, w, bs, ks)
}

fn fill_bases(gamma: f64, a: f64, x: &[f64], w: &[f64], bs: &mut [f64], ks: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked above).
        return unsafe { fill_bases_avx2(gamma, a, x, w, bs, ks) };
    }
    fill_bases_generic(gamma, a, x, w, bs, ks)
}

fn evaluate(s: f64, gamma: f64, sin2: &[f64], weight: &[f64], data: &[f64], a: f64) -> Eval {
    // Per chunk, first B and k for every sample (a branch-free loop the
    // compiler vectorises), then the sums in sample order.
    const CHUNK: usize = 64;
    let mut e = Eval { cost: 0.0, jss: 0.0, jsg: 0.0, jgg: 0.0, rs: 0.0, rg: 0.0, hsg: 0.0, hgg: 0.0, max_res: 0.0 };
    let (mut bs, mut ks) = ([0.0; CHUNK], [0.0; CHUNK]);
    for ((x, w), d) in sin2.chunks(CHUNK).zip(weight.chunks(CHUNK)).zip(data.chunks(CHUNK)) {
        fill_bases(gamma, a, x, w, &mut bs, &mut ks);
        for ((&b, &k), &d) in bs.iter().zip(&ks).zip(d) {
            let (m, ds, de, d2g) = terms(s, a, b, k);
            let dg = s * de;
            let r = m - d;
            e.cost += r * r;
            e.jss += ds * ds;
            e.jsg += ds * dg;
            e.jgg += dg * dg;
            e.rs += ds * r;
            e.rg += dg * r;
            e.hsg += de * r;
            e.hgg += d2g * r;
            e.max_res = e.max_res.max(r.abs());
        }
    }
    e.hgg *= s;
    e
}

/// Sum of squared residuals of the lobe (s, g) against `data` (what the fit minimises).
pub fn cost(s: f64, g: f64, sin2: &[f64], weight: &[f64], data: &[f64], c: f64) -> f64 {
    evaluate(s, g * g, sin2, weight, data, 0.5 * (c + 1.0)).cost
}

/// A starting point (s, g) from the data: s at the smallest angle, g from the
/// half-maximum angle of the plain model.
pub fn initial_guess(sin2: &[f64], weight: &[f64], data: &[f64], c: f64) -> (f64, f64) {
    let a = 0.5 * (c + 1.0);
    // Samples run from theta = 90 degrees down to ~0: the last is the peak.
    let n = data.len();
    let s0 = (data[n - 1] / weight[n - 1]).max(f64::MIN_POSITIVE);
    let half = (0..n).rev().find(|&k| data[k] < 0.5 * s0 * weight[k]).unwrap_or(0);
    let g0 = ((2f64.powf(1.0 / a) - 1.0) / (4.0 * sin2[half].max(1e-12))).sqrt();
    (s0, g0)
}

/// Fits (s, g) to `data` at samples with sin^2 theta = `sin2` and model weight
/// `weight` (1 for the plain variant, cos^2 theta for the cos variant), from `start` = (s, g).
pub fn fit(sin2: &[f64], weight: &[f64], data: &[f64], c: f64, start: (f64, f64)) -> Fit {
    let a = 0.5 * (c + 1.0);
    let (mut s, mut gamma) = (start.0.max(0.0), start.1 * start.1);
    let mut here = evaluate(s, gamma, sin2, weight, data, a);
    let mut lambda = 1e-3;
    let mut converged = false;
    let mut iterations = 0;
    let mut evaluations = 1;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let Eval { cost: current, jss, jsg, jgg, rs, rg, hsg, hgg, .. } = here;
        // A variable on its bound whose gradient pushes it outwards is held there.
        let free_s = !(s == 0.0 && rs > 0.0);
        let free_g = !(gamma == 0.0 && rg > 0.0) && jgg > 0.0;
        let projected = |x: f64, jj: f64, free: bool| if free && jj > 0.0 { x * x / jj } else { 0.0 };
        let grad = (projected(rs, jss, free_s) + projected(rg, jgg, free_g)).sqrt();
        if grad <= 1e-9 * current.sqrt() + f64::MIN_POSITIVE {
            converged = true;
            break;
        }
        // Solve (H + lambda diag(J^T J)) d = -J^T r in the free variables, H
        // the full Hessian of cost/2 (J^T J + sum r d2m): the residuals are
        // 10-30 % of the data, so Gauss-Newton alone would converge only
        // linearly. Damping grows until the system is positive definite.
        let mut accepted = false;
        while lambda < 1e16 {
            let (a11, a22, a12) = (jss * (1.0 + lambda), (jgg + hgg) + lambda * jgg, jsg + hsg);
            let step = match (free_s, free_g) {
                (true, true) => {
                    let det = a11 * a22 - a12 * a12;
                    (a11 > 0.0 && a22 > 0.0 && det > 0.0)
                        .then(|| ((-rs * a22 + rg * a12) / det, (-rg * a11 + rs * a12) / det))
                }
                (true, false) => (a11 > 0.0).then(|| (-rs / a11, 0.0)),
                (false, true) => (a22 > 0.0).then(|| (0.0, -rg / a22)),
                (false, false) => Some((0.0, 0.0)),
            };
            let Some((ds, dg)) = step else {
                lambda *= 4.0;
                continue;
            };
            let (s_new, g_new) = ((s + ds).max(0.0), (gamma + dg).max(0.0));
            let trial = evaluate(s_new, g_new, sin2, weight, data, a);
            evaluations += 1;
            if trial.cost <= current {
                let small_step = (s_new - s).abs() <= 1e-12 * s.abs() && (g_new - gamma).abs() <= 1e-12 * gamma.abs();
                let small_gain = current - trial.cost <= 1e-15 * current;
                s = s_new;
                gamma = g_new;
                here = trial;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                converged = small_step || small_gain;
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            // No step lowers the cost: a minimum to rounding if the projected
            // gradient is small too.
            converged = grad <= 1e-6 * current.sqrt();
            break;
        }
        if converged {
            break;
        }
    }
    let norm2: f64 = data.iter().map(|d| d * d).sum::<f64>().sqrt();
    let max_data = data.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let (current, max_res) = (here.cost, here.max_res);
    Fit {
        s,
        g: gamma.sqrt(),
        converged,
        iterations,
        evaluations,
        rel_l2: current.sqrt() / norm2,
        rel_max: max_res / max_data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tables::zh_math::samples;

    fn model(s: f64, gamma: f64, sin2: f64, weight: f64, a: f64) -> (f64, f64, f64, f64) {
        let (b, k) = base(gamma, sin2, weight, a);
        terms(s, a, b, k)
    }

    /// (sin^2, cos^2) of the fit samples as columns.
    fn columns() -> (Vec<f64>, Vec<f64>) {
        samples().into_iter().unzip()
    }

    #[test]
    fn recovers_known_lobes() {
        let (sin2, cos2) = columns();
        let ones = vec![1.0; sin2.len()];
        for &(s, g, c) in &[(1.0, 0.3, 2.0), (2.5e-3, 40.0, 1.02), (7.0, 0.0, 3.02), (1e-5, 150.0, 2.5)] {
            for weight in [&ones, &cos2] {
                let a = 0.5 * (c + 1.0);
                let data: Vec<f64> =
                    sin2.iter().zip(weight.iter()).map(|(&x, &w)| model(s, g * g, x, w, a).0).collect();
                let start = initial_guess(&sin2, weight, &data, c);
                let f = fit(&sin2, weight, &data, c, start);
                assert!(f.converged, "{f:?}");
                assert!((f.s / s - 1.0).abs() < 1e-9, "s: {f:?} vs {s}");
                // Near g = 0 the model changes by 4 g^2: g below ~1e-7 is invisible in f64.
                assert!((f.g - g).abs() < 1e-9 * g + 1e-7, "g: {f:?} vs {g}");
                assert!(f.rel_l2 < 1e-10);
            }
        }
    }

    #[test]
    fn model_derivatives_match_finite_differences() {
        for &(s, gamma, x, w, a) in
            &[(1.3, 0.7, 0.4, 1.0, 1.5), (2e-3, 900.0, 0.9, 0.3, 1.01), (5.0, 1e-3, 0.05, 0.8, 2.01)]
        {
            let (_, ds, de, d2g) = model(s, gamma, x, w, a);
            let h = 1e-4 * gamma;
            let at = |g: f64| model(s, g, x, w, a);
            let central = |f: &dyn Fn(f64) -> f64| (f(gamma + h) - f(gamma - h)) / (2.0 * h);
            assert!((central(&|g| at(g).0) / (s * de) - 1.0).abs() < 1e-6, "dm/dgamma");
            assert!((central(&|g| at(g).1) / de - 1.0).abs() < 1e-6, "d2m/ds dgamma");
            assert!((central(&|g| s * at(g).2) / (s * d2g) - 1.0).abs() < 1e-6, "d2m/dgamma2");
            assert_eq!(model(2.0 * s, gamma, x, w, a).0, 2.0 * s * ds);
        }
    }

    #[test]
    fn avx2_bases_are_bit_identical_to_the_portable_ones() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let (sin2, cos2) = columns();
            for &(gamma, a) in &[(0.0, 1.01), (0.37, 1.5), (2.5e4, 2.01), (1e-9, 1.2)] {
                let n = sin2.len();
                let (mut b1, mut k1, mut b2, mut k2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                fill_bases_generic(gamma, a, &sin2, &cos2, &mut b1, &mut k1);
                // SAFETY: AVX2 is available (checked above).
                unsafe { fill_bases_avx2(gamma, a, &sin2, &cos2, &mut b2, &mut k2) };
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
                assert_eq!((bits(&b1), bits(&k1)), (bits(&b2), bits(&k2)), "gamma={gamma} a={a}");
            }
        }
    }

    #[test]
    fn optimum_on_the_bound_g_zero_converges() {
        // Data flatter than the model can be with g >= 0: (1 + 0.2 sin^2) cos^2.
        // The bounded optimum has g = 0 and s from the 1-D least squares.
        let (sin2, cos2) = columns();
        let data: Vec<f64> = sin2.iter().zip(&cos2).map(|(x, w)| (1.0 + 0.2 * x) * w).collect();
        let f = fit(&sin2, &cos2, &data, 2.0, (1.0, 0.5));
        assert!(f.converged, "{f:?}");
        assert_eq!(f.g, 0.0);
        let best_s = data.iter().zip(&cos2).map(|(d, w)| d * w).sum::<f64>() / cos2.iter().map(|w| w * w).sum::<f64>();
        assert!((f.s / best_s - 1.0).abs() < 1e-9, "{} vs {best_s}", f.s);
    }
}
