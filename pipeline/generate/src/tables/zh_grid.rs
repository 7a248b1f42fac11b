//! zh_convolution's grid and what its build, its error budget and the build context share: the
//! fit samples, the coefficient tables F_l (of S) and G_l (of D), the degree `auto` needs, and
//! the fits of one node (docs/maths.md section 4).

use super::preset::Preset;
use super::zh_fit::{fit, initial_guess, Fit};
use super::zh_math::{coefficients, d_lobe, s_lobe, samples, ThetaRule};
use ndarray::{Array2, ArrayD};
use twoscale_tables::axis::{Axis, AxisEncoding, DomainError};
use twoscale_tables::interp::interpolate;

/// beta_max(p) of the paper's grid, for p = 5.0, 4.8, ..., 0.2.
pub const PAPER_BETA_MAX: [f64; 25] = [
    0.058, 0.060, 0.062, 0.064, 0.066, 0.068, 0.071, 0.074, 0.078, 0.083, 0.085, 0.087, 0.090, 0.093, 0.098, 0.104,
    0.113, 0.127, 0.153, 0.211, 0.348, 0.461, 0.448, 0.261, 0.015,
];
pub const PAPER_DEGREE: usize = 100;
/// Default degree (the most `auto` uses): measured against the direct
/// integral, C_L for the sharpest lobe of the default domain (u = 100,
/// beta = 0.005, p = 5) is within 1.6e-3 of C at L = 1000 and 2.5e-7 at L = 2000.
pub const DEFAULT_DEGREE: usize = 2000;
/// `auto`: a node's sum stops at the first multiple of 16 past which the
/// remaining terms sum (in absolute value, |P_l| <= 1) below AUTO_TAIL of
/// C(0); the node is computed by the direct integral when what the last
/// quarter of the L terms contributes at the 1000 angles is not below
/// AUTO_TOLERANCE of max C (the series has not converged by L).
pub const AUTO_TAIL: f64 = 1e-6;
pub const AUTO_TOLERANCE: f64 = 1e-4;
/// Tolerance of the direct integral.
pub const EXACT_REL_TOL: f64 = 1e-9;

/// The 24 fit samples where C_L and fitted lobes are compared with the exact
/// C: k = 999 - round(999 (i/23)^2), dense near theta = 0 where the lobes peak.
pub fn comparison_samples() -> Vec<usize> {
    (0..24).map(|i| 999 - (999.0 * (i as f64 / 23.0).powi(2)).round() as usize).collect()
}

/// zh_convolution's axes and its values as stored (ln s, g, ln s_cos, g_cos).
pub type Fits = (Vec<Axis>, Vec<(String, ArrayD<f32>)>);

/// The values zh_convolution stores as their ln (value_encoding `ln`, docs/file_contract.md): the
/// scales s and s_cos, positive, change by up to 60 % of the lobe's peak across one beta cell,
/// where ln s is near linear. Read in ln, the cos lobe's interpolation error at off-grid
/// (c, p, beta) is 5-10 times smaller (measured for issue 60: 4.6 % of the peak to 0.48 % at
/// beta 0.1, p 0.9).
pub const LN_VALUES: [&str; 2] = ["s", "s_cos"];

/// A fitted value of zh_convolution (`values` as stored) at `point`: multilinear in the encoded
/// coordinates, then exp for s and s_cos.
pub fn fit_value(
    axes: &[Axis],
    values: &[(String, ArrayD<f32>)],
    name: &str,
    point: &[f64],
) -> Result<f64, DomainError> {
    let (_, v) = values.iter().find(|(n, _)| n == name).expect("a zh_convolution value");
    let x = interpolate(axes, &v.view(), point)?;
    Ok(if LN_VALUES.contains(&name) { x.exp() } else { x })
}

/// The grid: axes, and the physical beta at each (p index, beta index).
pub struct Grid {
    pub axes: Vec<Axis>,
    pub beta: Array2<f64>,
}

pub fn grid(preset: Preset) -> Grid {
    match preset {
        Preset::Paper => {
            let u: Vec<f64> = (0..=20)
                .map(|i| i as f64 / 20.0)
                .chain((2..=10).map(f64::from))
                .chain((3..=10).map(|i| 5.0 * i as f64))
                .chain((6..=10).map(|i| 10.0 * i as f64))
                .collect();
            let c: Vec<f64> = (0..11).map(|j| (302.0 - 20.0 * j as f64) / 100.0).collect();
            let p: Vec<f64> = (0..25).map(|k| (50.0 - 2.0 * k as f64) / 10.0).collect();
            let frac: Vec<f64> = (0..10).map(|m| (m as f64 + 0.5) / 10.0).collect();
            let beta = Array2::from_shape_fn((25, 10), |(k, m)| frac[m] * PAPER_BETA_MAX[k]);
            Grid {
                axes: vec![
                    Axis::new("u", u, AxisEncoding::Linear),
                    Axis::new("c", c, AxisEncoding::Linear),
                    Axis::new("p", p, AxisEncoding::Linear),
                    Axis::new("beta_over_beta_max", frac, AxisEncoding::Linear),
                ],
                beta,
            }
        }
        Preset::Default => {
            let axes = vec![
                Axis::uniform("u", AxisEncoding::ShiftedLog { shift: -1.0 }, 0.0, 100.0, 33),
                Axis::uniform("c", AxisEncoding::Linear, 1.02, 3.02, 11),
                Axis::uniform("p", AxisEncoding::Log, 0.2, 5.0, 17),
                Axis::uniform("beta", AxisEncoding::Log, 0.005, 0.5, 17),
            ];
            let beta = Array2::from_shape_fn((axes[2].len(), axes[3].len()), |(_, m)| axes[3].nodes[m]);
            Grid { axes, beta }
        }
    }
}

/// What each node yields.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeFit {
    pub(crate) plain: Fit,
    pub(crate) cos: Fit,
    /// Computed by the direct integral.
    pub(crate) exact: bool,
}

/// The fit samples as the fit needs them.
pub(crate) struct Samples {
    sin2: Vec<f64>,
    cos2: Vec<f64>,
    ones: Vec<f64>,
    pub(crate) theta: Vec<f64>,
}

impl Samples {
    pub(crate) fn new() -> Samples {
        let smp = samples();
        Samples {
            sin2: smp.iter().map(|x| x.0).collect(),
            cos2: smp.iter().map(|x| x.1).collect(),
            ones: vec![1.0; smp.len()],
            theta: smp.iter().map(|x| x.0.sqrt().asin()).collect(),
        }
    }
}

/// Fits both variants to `data`, warm-started from `previous` (the neighbouring
/// node), falling back to the data's own initial guess if that fails.
pub(crate) fn fit_both(smp: &Samples, data: &[f64], c: f64, previous: Option<&NodeFit>) -> (Fit, Fit) {
    let one = |weight: &[f64], warm: Option<Fit>| {
        // A neighbour on the bound s = 0 is no start: g is undetermined there.
        let warm = warm.filter(|w| w.s > 0.0 && w.converged);
        let guess = || initial_guess(&smp.sin2, weight, data, c);
        let first = fit(&smp.sin2, weight, data, c, warm.map_or_else(guess, |w| (w.s, w.g)));
        if first.converged || warm.is_none() {
            first
        } else {
            fit(&smp.sin2, weight, data, c, guess())
        }
    };
    (one(&smp.ones, previous.map(|p| p.plain)), one(&smp.cos2, previous.map(|p| p.cos)))
}

/// The plain and cos fits of a lobe given at the fit samples of docs/maths.md section 4
/// (`data`), warm-started from a neighbouring node's fits when given (a material's `zh_convolution`).
pub fn fit_lobe(data: &[f64], c: f64, previous: Option<(Fit, Fit)>) -> (Fit, Fit) {
    let previous = previous.map(|(plain, cos)| NodeFit { plain, cos, exact: false });
    fit_both(&Samples::new(), data, c, previous.as_ref())
}

/// Coefficient tables: F for every (u, c), G for every (p, beta), to degree `n`.
pub fn all_coefficients(grid: &Grid, rule: &ThetaRule, n: usize) -> (Array2<f64>, Array2<f64>) {
    let w = rule.weighted_legendre(n);
    let (us, cs) = (&grid.axes[0].nodes, &grid.axes[1].nodes);
    let uc: Vec<(f64, f64)> = us.iter().flat_map(|&u| cs.iter().map(move |&c| (u, c))).collect();
    let ps = &grid.axes[2].nodes;
    let pb: Vec<(f64, f64)> = grid.beta.indexed_iter().map(|((k, _), &b)| (ps[k], b)).collect();
    (s_coefficients(rule, &w, &uc), d_coefficients(rule, &w, &pb))
}

/// F_l of the lobes S(u, c), one row per (u, c) of `uc`; `w` the rule's
/// weighted Legendre matrix. A row does not depend on the other rows.
pub fn s_coefficients(rule: &ThetaRule, w: &Array2<f64>, uc: &[(f64, f64)]) -> Array2<f64> {
    let lobes: Vec<_> = uc.iter().map(|&(u, c)| move |s2: f64, c2: f64| s_lobe(s2, c2, u, c)).collect();
    coefficients(rule, w, &lobes)
}

/// G_l of the lobes D(beta, p), one row per (p, beta) of `pb` (see `s_coefficients`).
pub fn d_coefficients(rule: &ThetaRule, w: &Array2<f64>, pb: &[(f64, f64)]) -> Array2<f64> {
    let lobes: Vec<_> = pb.iter().map(|&(p, b)| move |s2: f64, c2: f64| d_lobe(s2, c2, p, b)).collect();
    coefficients(rule, w, &lobes)
}

/// `auto`: the degree one node needs, from its terms h_l = F_l G_l and
/// weights pi (2l + 1): C(0) = sum_l w_l h_l at the peak, and the terms past a
/// degree bound the truncation (|P_l| <= 1).
pub fn auto_degree(h: &[f64], weight: &[f64]) -> usize {
    let c0: f64 = h.iter().zip(weight).map(|(h, w)| h * w).sum::<f64>().abs();
    let mut tail = 0.0;
    let mut needed = h.len();
    for l in (0..h.len()).rev() {
        tail += (h[l] * weight[l]).abs();
        if tail > AUTO_TAIL * c0 {
            break;
        }
        needed = l;
    }
    (needed.div_ceil(16).max(1) * 16).min(h.len())
}
