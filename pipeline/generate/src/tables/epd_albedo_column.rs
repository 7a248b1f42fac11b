//! epd_albedo's rule (docs/maths.md section 9): E(theta_i; p, beta) at every theta_i node of one
//! (p, beta), over the half vector (x = ln tan theta_h, phi) as `epd_albedo_math` sets it up, with
//! what does not depend on theta_i computed once per (p, beta).
//!
//! The panels in x of every theta_i are one list (`panels`) cut at the incidence's ln tan theta_max,
//! with a break at ln tan theta_c. So a panel between two breaks of the list, the bulk of every
//! incidence's panels, has the same nodes for every theta_i: its theta_h, D and weight are shared.
//! Below theta_c (no horizon cut) phi_max = pi and the phi nodes, hence h, are shared too. What is
//! left per point depends on h only through h_x = sin theta_h cos phi:
//!     i.h = sin theta_i h_x + mu cos theta_h,   o_z = 2 (i.h) cos theta_h - mu,
//!     tan^2 theta_o = (1 - o_z^2) / o_z^2,      G2 = 1 / (1 + Lambda_i + Lambda(beta^2 tan^2 theta_o)),
//! with Lambda from `LambdaTable` (no logarithm) and, above theta_c, cos phi by `cos_0_pi`.
//! Only the panels that hold theta_c or end at theta_max get nodes of their own.

use super::epd_albedo_math::Incidence;
use super::epd_math::norm;
use super::lambda_table::LambdaTable;
use crate::numerics::legendre::gauss_legendre;
use crate::numerics::vector_math::{cos_0_pi, exp};
use std::f64::consts::PI;

/// Gauss-Legendre nodes per x panel and in phi. Against the adaptive reference (Lambda by
/// quadrature) at 1,600 random points over four regions of p: 1.1e-6 at most; 2.3e-6 with 6 per
/// panel; 5e-6 with 8 in phi (docs/maths.md section 9).
pub const NODES: usize = 7;
pub const PHI_NODES: usize = 10;
/// Above P_SHARP, PHI_NODES_SHARP in phi: the near-disk slope density of large p turns Lambda on
/// within a few per cent of a = 1, a near-kink of G2 in phi (3.7e-6 with 12 nodes at p = 4.1;
/// 6e-7 with 16). Only 2 % of the p nodes (uniform in 1/p) lie above it.
pub const P_SHARP: f64 = 1.5;
pub const PHI_NODES_SHARP: usize = 16;

/// One node in theta_h: its weight times D and the measure (2 w_x sin^2 cos theta_h D), and the
/// factors the phi rule reads.
struct HalfNode {
    weight: f64,
    st: f64,
    ct: f64,
    /// tan 2 theta_h, for phi_max = acos(-cot theta_i / tan 2 theta_h).
    tan2: f64,
}

/// The Gauss-Legendre rules and (p, beta)'s constants.
struct Rule<const M: usize> {
    gx: Vec<f64>,
    gw: Vec<f64>,
    /// (t_k + 1)/2 and the weights of the phi rule on [-1, 1]: phi_k = phi_max (t_k + 1)/2.
    phi_at: [f64; M],
    phi_w: [f64; M],
    /// cos phi_k with phi_max = pi.
    cos_full: [f64; M],
    beta: f64,
    ln_beta: f64,
    p: f64,
    /// N(p) / beta^2.
    n: f64,
}

impl<const M: usize> Rule<M> {
    fn new(p: f64, beta: f64) -> Rule<M> {
        let (gx, gw) = gauss_legendre(NODES);
        let (px, pw) = gauss_legendre(M);
        let phi_at: [f64; M] = std::array::from_fn(|k| 0.5 * (px[k] + 1.0));
        Rule {
            gx,
            gw,
            phi_at,
            phi_w: std::array::from_fn(|k| pw[k]),
            cos_full: std::array::from_fn(|k| (0.5 * PI * (px[k] + 1.0)).cos()),
            beta,
            ln_beta: beta.ln(),
            p,
            n: norm(p) / (beta * beta),
        }
    }

    /// The nodes of the panel [a, b], as `composite_rule` places them. With tan theta_h = e^x:
    /// cos theta_h = 1/sqrt(1 + tan^2), (tan theta_h / beta)^(2p) = e^(2p (x - ln beta)),
    /// tan 2 theta_h = 2 tan / (1 - tan^2).
    fn panel(&self, a: f64, b: f64, out: &mut Vec<HalfNode>) {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        for (g, w) in self.gx.iter().zip(&self.gw) {
            let x = c + h * g;
            let tan_h = exp(x);
            let ct = 1.0 / (1.0 + tan_h * tan_h).sqrt();
            let st = tan_h * ct;
            let d = self.n * exp(-exp(2.0 * self.p * (x - self.ln_beta))) / (ct * ct * ct * ct);
            // dtheta_h = sin cos dx; dh = sin theta_h dtheta_h dphi; 2 for phi in [-phi_max, phi_max].
            out.push(HalfNode {
                weight: 2.0 * h * w * st * ct * st * d,
                st,
                ct,
                tan2: 2.0 * tan_h / (1.0 - tan_h * tan_h),
            });
        }
    }
}

/// One incidence: mu, sin theta_i, cot theta_i and Lambda_i.
struct Incident {
    mu: f64,
    sin_i: f64,
    cot_i: f64,
    lambda_i: f64,
}

impl Incident {
    /// int_0^phi_max D G2 (i.h)/mu over the phi nodes of `node`, times its weight; `cut` above theta_c.
    #[inline]
    fn node_sum<const M: usize>(&self, rule: &Rule<M>, table: &LambdaTable, node: &HalfNode, cut: bool) -> f64 {
        let phi_max = if cut { (-self.cot_i / node.tan2).clamp(-1.0, 1.0).acos() } else { PI };
        let cos: [f64; M] =
            if cut { std::array::from_fn(|k| cos_0_pi(phi_max * rule.phi_at[k])) } else { rule.cos_full };
        let b2 = rule.beta * rule.beta;
        // Three passes, the first and last branch-free (SIMD): i.h and tan^2 theta_o, Lambda, the sum.
        let (mut ih, mut t) = ([0.0; M], [0.0; M]);
        for k in 0..M {
            ih[k] = self.sin_i * node.st * cos[k] + self.mu * node.ct;
            let oz = 2.0 * ih[k] * node.ct - self.mu;
            // Below the horizon (o_z <= 0 or i.h <= 0, by rounding only at these nodes): t = inf, G2 = 0.
            t[k] = if oz > 0.0 && ih[k] > 0.0 { b2 * ((1.0 - oz) * (1.0 + oz)) / (oz * oz) } else { f64::INFINITY };
        }
        let lambda: [f64; M] = std::array::from_fn(|k| table.at_t(t[k]));
        let mut sum = 0.0;
        for k in 0..M {
            sum += rule.phi_w[k] * ih[k] / (1.0 + self.lambda_i + lambda[k]);
        }
        node.weight * 0.5 * phi_max * sum
    }
}

/// E at each of `thetas` for (table.p, beta).
pub fn albedo_column(table: &LambdaTable, beta: f64, thetas: &[f64]) -> Vec<f64> {
    if table.p > P_SHARP {
        column(&Rule::<PHI_NODES_SHARP>::new(table.p, beta), table, thetas)
    } else {
        column(&Rule::<PHI_NODES>::new(table.p, beta), table, thetas)
    }
}

fn column<const M: usize>(rule: &Rule<M>, table: &LambdaTable, thetas: &[f64]) -> Vec<f64> {
    let beta = rule.beta;
    let incidences: Vec<(Incidence, Incident)> = thetas
        .iter()
        .map(|&theta| {
            let (sin_t, mu) = theta.sin_cos();
            let inc = Incidence::new(mu);
            let a = beta * sin_t / mu;
            let incident = Incident { mu, sin_i: inc.i[0], cot_i: mu / inc.i[0], lambda_i: table.at_t(a * a) };
            (inc, incident)
        })
        .collect();
    let hi_max = incidences.iter().map(|(inc, _)| inc.theta_max.tan().ln()).fold(f64::NEG_INFINITY, f64::max);
    // Every panel between two breaks below hi_max, shared by the incidences that reach past it.
    let breaks = panels(beta, table.p, hi_max);
    let inner = &breaks[..breaks.len() - 1];
    let mut shared = Vec::with_capacity(NODES * inner.len());
    for w in inner.windows(2) {
        rule.panel(w[0], w[1], &mut shared);
    }
    let mut own = Vec::with_capacity(3 * NODES);
    incidences
        .iter()
        .map(|(inc, incident)| {
            let hi = inc.theta_max.tan().ln();
            let x_c = inc.x_c();
            // Panels [b_j, b_j+1] with b_j+1 < hi, then [b_J, hi]; the one holding x_c split there.
            let below = inner.partition_point(|&b| b < hi);
            let mut sum = 0.0;
            let mut own_panel = |a: f64, b: f64, sum: &mut f64| {
                let pieces: &[(f64, f64)] = if a < x_c && x_c < b { &[(a, x_c), (x_c, b)] } else { &[(a, b)] };
                for &(a, b) in pieces {
                    own.clear();
                    rule.panel(a, b, &mut own);
                    *sum += own.iter().map(|node| incident.node_sum(rule, table, node, a >= x_c)).sum::<f64>();
                }
            };
            for j in 0..below - 1 {
                let (a, b) = (inner[j], inner[j + 1]);
                if a < x_c && x_c < b {
                    own_panel(a, b, &mut sum);
                } else {
                    sum += shared[NODES * j..NODES * (j + 1)]
                        .iter()
                        .map(|node| incident.node_sum(rule, table, node, a >= x_c))
                        .sum::<f64>();
                }
            }
            own_panel(inner[below - 1], hi, &mut sum);
            sum / incident.mu
        })
        .collect()
}

/// The panels in x = ln tan theta_h, with y = x - ln beta (D's scale):
/// - from ln(X_LOW beta) (below it lies < 1e-8 of D's mass) to y = -EDGE, widths PANEL, 2 PANEL,
///   4 PANEL, ... downwards: there the integrand is ~ e^(2x) times factors that vary slowly in x;
/// - D's edge, |y| < EDGE: min(PANEL, 1/p) (D = exp(-e^(2py)));
/// - above it, widths doubling from PANEL, at most TAIL / sqrt(p) (D's mass, ~ e^(3y - e^(2py))
///   in x, peaks in a bump 1/sqrt(6p) wide) while that mass is within e^-46 of its peak, then freely.
///
/// The 0.10.0 rule took PANEL-wide panels below the edge (half of its points, for a few per cent
/// of E) and doubled from x = 2 on whatever p: 4- to 16-wide panels across the heavy tails' mass
/// (p < 0.1), where its error peaked (2.5e-5 near grazing, against 1.1e-6 now: docs/maths.md section 9).
const X_LOW: f64 = 1e-4;
const PANEL: f64 = 0.5;
const EDGE: f64 = 1.5;
const TAIL: f64 = 0.35;
/// ln of the mass ratio below which a tail panel is free to grow (e^-46 ~ 1e-20).
const DEAD: f64 = 46.0;

/// The breaks of `panels` from ln(X_LOW beta) to the first at or past `hi`.
pub fn panels(beta: f64, p: f64, hi: f64) -> Vec<f64> {
    let ln_beta = beta.ln();
    let lo = (X_LOW * beta).ln();
    let mut breaks = vec![];
    let (mut x, mut width) = (ln_beta - EDGE, PANEL);
    while x > lo {
        breaks.push(x);
        x -= width;
        width *= 2.0;
    }
    breaks.push(lo);
    breaks.reverse();
    let edge = PANEL.min(1.0 / p);
    let mut x = ln_beta - EDGE;
    while x < ln_beta + EDGE && x < hi {
        x += edge;
        breaks.push(x);
    }
    let (cap, y_dead) = (TAIL / p.sqrt(), dead_tail(p));
    let mut width = PANEL;
    while x < hi {
        x += if x - ln_beta < y_dead { width.min(cap.max(PANEL)) } else { width };
        breaks.push(x);
        width *= 2.0;
    }
    breaks
}

/// y beyond the peak of L(y) = 3y - e^(2py) where L falls DEAD below its peak L* (at e^(2py*) = 3/(2p)):
/// the fixed point of y = ln(3y - L* + DEAD) / (2p), a contraction there.
fn dead_tail(p: f64) -> f64 {
    let y_peak = (1.5 / p).ln() / (2.0 * p);
    let l_peak = 3.0 * y_peak - 1.5 / p;
    (0..60).fold(y_peak + 1.0, |y, _| (3.0 * y - l_peak + DEAD).ln() / (2.0 * p))
}

/// The rule text for manifests.
pub fn rule_text() -> String {
    format!(
        "half vector: x = ln tan theta_h from ln({X_LOW:e} beta) to ln tan(pi/4 + theta_i/2) in panels (y = x - ln beta): \
         below y = -{EDGE} widths {PANEL}, doubling downwards; min({PANEL}, 1/p) for |y| < {EDGE}; above, doubling from {PANEL} \
         but at most max({PANEL}, {TAIL}/sqrt p) while e^(3y - e^(2py)) is within e^-{DEAD} of its peak; a break at theta_h = \
         pi/4 - theta_i/2; {NODES} Gauss-Legendre nodes per panel; phi in [0, phi_max(theta_h)] (o_z > 0) by {PHI_NODES}-node \
         Gauss-Legendre ({PHI_NODES_SHARP} for p > {P_SHARP}), doubled by symmetry; Lambda from a cubic per cell of a^2's float bits (lambda_table)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tables::epd_albedo_math::albedo_reference;

    /// Against nested adaptive Gauss-Kronrod with Lambda by its own quadrature at every direction
    /// (`albedo_reference`), across p, beta and theta_i, grazing incidence included.
    #[test]
    fn column_against_the_adaptive_reference() {
        let thetas = [0.0, 0.3, 1.2, 1.55, (1e4f64).atan(), (1e6f64).atan()];
        for (p, beta) in [(0.06, 0.3), (0.4, 0.005), (1.0, 0.07), (4.8, 0.18)] {
            let column = albedo_column(&LambdaTable::new(p), beta, &thetas);
            for (&theta, e) in thetas.iter().zip(column) {
                let want = albedo_reference(p, beta, theta, 1e-9);
                assert!((e - want).abs() < 2e-6, "p {p} beta {beta} theta {theta}: {e} vs {want}");
            }
        }
    }

    #[test]
    fn panels_cover_the_lobe_and_stop_past_hi() {
        for (p, beta, hi) in [(0.05, 0.005, 14.5), (5.0, 0.5, 0.0), (1.0, 0.05, 37.0)] {
            let b = panels(beta, p, hi);
            assert!(b.windows(2).all(|w| w[0] < w[1]), "{b:?}");
            assert_eq!(b[0], (X_LOW * beta).ln());
            assert!(b[b.len() - 1] >= hi && b[b.len() - 2] < hi, "{b:?}");
            // D's edge in panels of at most min(PANEL, 1/p).
            let edge = PANEL.min(1.0 / p);
            assert!(b
                .windows(2)
                .filter(|w| (w[0] - beta.ln()).abs() < EDGE && w[1] < hi)
                .all(|w| w[1] - w[0] <= edge + 1e-12));
        }
        // Heavy tails keep panels of at most TAIL / sqrt(p) far into the tail; light ones do not.
        let tail = |p: f64| -> Vec<f64> {
            let b = panels(0.005, p, 14.5);
            b.windows(2).filter(|w| w[0] >= 0.005f64.ln() + EDGE && w[1] < 14.5).map(|w| w[1] - w[0]).collect()
        };
        assert!(
            tail(0.05).iter().all(|&w| w <= TAIL / 0.05f64.sqrt() + 1e-12) && tail(0.05).len() > 10,
            "{:?}",
            tail(0.05)
        );
        assert!(tail(1.0).iter().any(|&w| w > 4.0), "{:?}", tail(1.0));
        assert!(dead_tail(0.05) > 40.0 && dead_tail(1.0) < 2.5);
    }
}
