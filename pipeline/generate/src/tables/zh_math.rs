//! The diffraction lobe convolved by the EPD normal distribution on the
//! sphere (docs/maths.md section 4): zonal-harmonic coefficients, the truncated sum
//! C_L, and the direct 2-D integral C used as the exact reference.
//!
//! Lobes are written in the angle theta (t = cos theta) so that 1 - t^2 =
//! sin^2 theta carries no cancellation near the peak at theta = 0.

use crate::numerics::legendre::{composite_rule, legendre_all};
use crate::numerics::quadrature;
use ndarray::Array2;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use twoscale_tables::lobe::LobeParams;

/// S(t; u, c) = (1 + 4 u^2 (1 - t^2))^(-(c+1)/2) t^2 at t = cos(theta), theta in [0, pi/2].
pub fn s_lobe(sin2: f64, cos2: f64, u: f64, c: f64) -> f64 {
    (-0.5 * (c + 1.0) * (4.0 * u * u * sin2).ln_1p()).exp() * cos2
}

/// D(t; p, beta) = exp(-((1 - t^2) / (t^2 beta^2))^p) / t^4 at t = cos(theta).
pub fn d_lobe(sin2: f64, cos2: f64, p: f64, beta: f64) -> f64 {
    if cos2 == 0.0 {
        return 0.0;
    }
    let x = sin2 / (cos2 * beta * beta);
    (-x.powf(p)).exp() / (cos2 * cos2)
}

/// Number of fit samples: sin(theta_k) = 1 - k/1000, k = 0..999 (docs/maths.md section 4).
pub const SAMPLES: usize = 1000;

/// (sin^2, cos^2) of the fit samples.
pub fn samples() -> Vec<(f64, f64)> {
    (0..SAMPLES).map(sample).collect()
}

/// (sin^2, cos^2) of fit sample k.
pub fn sample(k: usize) -> (f64, f64) {
    let s = 1.0 - k as f64 / SAMPLES as f64;
    // cos^2 = 1 - s^2 = (1 - s)(1 + s), exact for s near 1.
    (s * s, (k as f64 / SAMPLES as f64) * (1.0 + s))
}

/// The fitted K-correlation lobe s (1 + 4 g^2 sin^2)^(-(c+1)/2), times cos^2
/// for the cos variant (`cos2` = 1 otherwise).
pub fn fitted_lobe(s: f64, g: f64, c: f64, sin2: f64, cos2: f64) -> f64 {
    s * (1.0 + 4.0 * g * g * sin2).powf(-0.5 * (c + 1.0)) * cos2
}

/// How far a fitted lobe (s, g) for c is from the convolution C given at
/// fit samples `ks`: max_k |lobe - C_k| / max C, the lobe times cos^2 for the
/// cos variant.
pub fn lobe_error(s: f64, g: f64, c: f64, cos_variant: bool, ks: &[usize], exact: &[f64]) -> f64 {
    let max_c = exact.iter().fold(0.0f64, |m, x| m.max(*x));
    ks.iter()
        .zip(exact)
        .map(|(&k, e)| {
            let (sin2, cos2) = sample(k);
            (fitted_lobe(s, g, c, sin2, if cos_variant { cos2 } else { 1.0 }) - e).abs()
        })
        .fold(0.0, f64::max)
        / max_c
}

/// A composite Gauss-Legendre rule in theta on [0, pi/2] for the coefficient
/// integrals int_0^1 f(t) P_l(t) dt = int f(cos th) P_l(cos th) sin th dth:
/// geometric panels (ratio `ratio`) from 1e-7 towards both ends, where the
/// lobes are narrowest (S and D peak at theta = 0 with widths down to ~1/(2u)
/// and ~beta; D of small p and large beta peaks near theta = pi/2), and no
/// panel wider than min(`max_step`, 10 / degree) (P_l oscillates with period 2 pi / l).
#[derive(Clone, Debug)]
pub struct ThetaRule {
    pub sin2: Vec<f64>,
    pub cos2: Vec<f64>,
    pub cos: Vec<f64>,
    /// Quadrature weight times sin(theta) (dt = sin theta dtheta).
    pub weight: Vec<f64>,
}

impl ThetaRule {
    pub fn new(degree: usize, panel_nodes: usize, ratio: f64, max_step: f64) -> ThetaRule {
        let step = max_step.min(10.0 / degree.max(1) as f64);
        let edge = 0.05;
        let mut low = vec![0.0];
        let mut x = 1e-7;
        while x < edge {
            low.push(x);
            x *= ratio;
        }
        let mut breaks = low.clone();
        let n_mid = ((FRAC_PI_2 - 2.0 * edge) / step).ceil() as usize;
        for i in 0..=n_mid {
            breaks.push(edge + (FRAC_PI_2 - 2.0 * edge) * i as f64 / n_mid as f64);
        }
        breaks.extend(low.iter().rev().map(|x| FRAC_PI_2 - x));
        // No panel wider than the step: P_l must be resolved everywhere.
        let mut fine = vec![0.0];
        for pair in breaks.windows(2) {
            let pieces = ((pair[1] - pair[0]) / step).ceil().max(1.0) as usize;
            fine.extend((1..=pieces).map(|i| pair[0] + (pair[1] - pair[0]) * i as f64 / pieces as f64));
        }
        let (theta, w) = composite_rule(&fine, panel_nodes);
        // Near pi/2 compute cos from the gap to pi/2, without cancellation.
        let cos: Vec<f64> = theta.iter().map(|&th| (FRAC_PI_2 - th).sin()).collect();
        let sin: Vec<f64> = theta.iter().map(|th| th.sin()).collect();
        ThetaRule {
            sin2: sin.iter().map(|s| s * s).collect(),
            cos2: cos.iter().map(|c| c * c).collect(),
            weight: w.iter().zip(&sin).map(|(w, s)| w * s).collect(),
            cos,
        }
    }

    /// The rule every build uses for degree `degree` (see `settings`).
    pub fn standard(degree: usize) -> ThetaRule {
        ThetaRule::new(degree, 24, 1.2, 0.02)
    }

    /// A refined rule (smaller panels, more nodes), to measure convergence.
    pub fn refined(degree: usize) -> ThetaRule {
        ThetaRule::new(degree, 32, 1.12, 0.01)
    }

    pub fn len(&self) -> usize {
        self.cos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cos.is_empty()
    }

    /// Weighted Legendre matrix W[j, l] = weight_j P_l(t_j), so that the
    /// coefficients of f are (f(t_j))_j . W.
    pub fn weighted_legendre(&self, degree: usize) -> Array2<f64> {
        let mut m = Array2::zeros((self.len(), degree));
        let mut p = vec![0.0; degree];
        for j in 0..self.len() {
            legendre_all(self.cos[j], &mut p);
            for l in 0..degree {
                m[[j, l]] = self.weight[j] * p[l];
            }
        }
        m
    }
}

/// Coefficients int_0^1 f(t) P_l(t) dt (l < degree) of many lobes at once:
/// row i of the result belongs to lobes[i], a function of (sin^2, cos^2).
/// Blocks of `block_rows` rows are products of their own, in parallel; a
/// row's arithmetic does not depend on the other rows of its block (the
/// product accumulates each entry over the rule in the same order), so the
/// result is the same whatever the blocks and threads.
pub fn coefficients<F: Fn(f64, f64) -> f64 + Sync>(
    rule: &ThetaRule,
    legendre: &Array2<f64>,
    lobes: &[F],
) -> Array2<f64> {
    let blocks: Vec<Array2<f64>> = lobes
        .par_chunks(block_rows(lobes.len()))
        .map(|block| {
            let values =
                Array2::from_shape_fn((block.len(), rule.len()), |(i, j)| block[i](rule.sin2[j], rule.cos2[j]));
            values.dot(legendre)
        })
        .collect();
    let views: Vec<_> = blocks.iter().map(|b| b.view()).collect();
    ndarray::concatenate(ndarray::Axis(0), &views).unwrap_or_else(|_| Array2::zeros((0, legendre.ncols())))
}

/// Rows per block of `coefficients`: each block's product packs the whole Legendre matrix (nodes x degree) again,
/// so as few blocks as keep every thread busy, of 128 to 1024 rows (1024 rows of 10^4 nodes hold 80 MB of lobe
/// values). A material's zh_convolution accuracy (1128 rows, 2 threads): 0.66 s in blocks of 128, 0.53 s in 2 blocks.
fn block_rows(rows: usize) -> usize {
    rows.div_ceil(rayon::current_num_threads()).clamp(128, 1024)
}

/// Q[l, k] = pi (2l + 1) P_l(cos theta_k) at the fit samples: C_L = (F_l G_l)_l . Q.
pub fn synthesis_matrix(degree: usize) -> Array2<f64> {
    let mut q = Array2::zeros((degree, SAMPLES));
    let mut p = vec![0.0; degree];
    for (k, (_, cos2)) in samples().into_iter().enumerate() {
        legendre_all(cos2.sqrt(), &mut p);
        for l in 0..degree {
            q[[l, k]] = PI * (2 * l + 1) as f64 * p[l];
        }
    }
    q
}

/// sin^2(x/2), the haversine.
fn hav(x: f64) -> f64 {
    let s = (0.5 * x).sin();
    s * s
}

/// Geometric breakpoints from `first` (ratio 4) strictly inside (lo, hi), offset from `origin` in `direction`.
fn push_geometric(breaks: &mut Vec<f64>, origin: f64, direction: f64, first: f64, lo: f64, hi: f64) {
    let mut d = first;
    while d < hi - lo {
        let x = origin + direction * d;
        if x > lo && x < hi {
            breaks.push(x);
        }
        d *= 4.0;
    }
}

/// The exact convolution C(theta_h) = int S(h.m) D(n.m) dm as a direct 2-D
/// integral over m = (theta_m, phi) around n, by nested adaptive Gauss-Kronrod
/// to relative tolerance `rel_tol`. The angle gamma between h and m comes from
/// the haversine formula (accurate when m is close to h), and breakpoints sit
/// at the narrow features: the S peak at m = h (width ~ 1/(2u)), D's lobe at
/// theta_m ~ beta and near pi/2.
pub fn exact_convolution(theta_h: f64, x: &LobeParams, rel_tol: f64) -> f64 {
    let LobeParams { u, c, p, beta } = *x;
    let (sin_h, _) = theta_h.sin_cos();
    let width = 0.5 / u.max(1e-3);
    let inner = |theta_m: f64| {
        let sin_m = theta_m.sin();
        let dtheta = hav(theta_m - theta_h);
        let f = |phi: f64| {
            let hv = dtheta + sin_m * sin_h * hav(phi);
            let t = 1.0 - 2.0 * hv;
            if t <= 0.0 {
                return 0.0;
            }
            s_lobe(4.0 * hv * (1.0 - hv), t * t, u, c)
        };
        let mut breaks = vec![0.0];
        let scale = (sin_m * sin_h).sqrt();
        if scale > 0.0 {
            push_geometric(&mut breaks, 0.0, 1.0, width / scale, 0.0, PI);
        }
        breaks.push(PI);
        2.0 * quadrature::integrate(f, &breaks, rel_tol, 0.0).value
    };
    let outer = |theta_m: f64| {
        let (s, c_m) = theta_m.sin_cos();
        let c_m = if theta_m > 1.0 { (FRAC_PI_2 - theta_m).sin() } else { c_m };
        let d = d_lobe(s * s, c_m * c_m, p, beta);
        if d == 0.0 {
            0.0
        } else {
            d * s * inner(theta_m)
        }
    };
    let mut breaks = vec![0.0, FRAC_PI_2];
    push_geometric(&mut breaks, theta_h, 1.0, width, 0.0, FRAC_PI_2);
    push_geometric(&mut breaks, theta_h, -1.0, width, 0.0, FRAC_PI_2);
    if theta_h > 0.0 && theta_h < FRAC_PI_2 {
        breaks.push(theta_h);
    }
    push_geometric(&mut breaks, 0.0, 1.0, 0.1 * beta, 0.0, FRAC_PI_2);
    push_geometric(&mut breaks, FRAC_PI_2, -1.0, 1e-4, 0.0, FRAC_PI_2);
    breaks.sort_by(f64::total_cmp);
    breaks.dedup();
    quadrature::integrate(outer, &breaks, rel_tol, 0.0).value
}
