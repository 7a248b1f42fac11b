//! How `zh_lobe` is decoded (value encoding `ln_control_variates`): the
//! stored ln C interpolated with closed-form control variates whose weights
//! are taken at the query point.
//!
//! In the two limits of C = S * D the parameter dependence of ln C is known:
//! - diffraction lobe the narrower (w_S << w_D): C ~ m_S(u, c) D, so ln C
//!   carries ln m_S, curved in ln(1 + 4u^2) and in c;
//! - NDF the narrower: C ~ m_D(p, beta) S(theta), so ln C carries
//!   b = ln m_D - (c+1)/2 ln(1 + 4u^2 sin^2 theta) + ln((cos^2 theta + s2)/(1 + s2)),
//!   S's t^2 factor smoothed by the NDF's slope variance s2.
//!
//! With lambda = (w_D^2 / (w_S^2 + w_D^2))^2, w_S^2 = 1/(1 + 4u^2), w_D = beta/(2p),
//! evaluated once at the query point q:
//!   ln C(q) = I[ln C - lambda ln m_S - (1 - lambda) b](q) + lambda ln m_S(q) + (1 - lambda) b(q),
//! I the multilinear interpolation over the table's 32 corners (b at each
//! corner's own angle, from the derived axis). The same terms subtracted at
//! the nodes with node-wise weights made the error worse (the weights are
//! curved across the nodes); taken at q, a weight only scales its term's own
//! interpolation error, which the term then cancels where its limit holds
//! (`twoscale bench --table zh_lobe`: p99 4.3 % -> 2.5 % against exp of the
//! interpolated ln C).

use super::epd_math::norm;
use super::kcorr_math::mass_inside;
use crate::derived::Derivation;
use crate::grid::{Axis, DomainError};
use crate::interp::interpolate_with;
use crate::numerics::special::ln_gamma;
use ndarray::ArrayD;
use std::f64::consts::PI;

/// ln m_S: m_S = pi int_0^1 (1 + 4u^2 x)^(-(c+1)/2) dx, the projected solid
/// angle integral of the K-correlation lobe (1 + 4u^2 sin^2)^(-(c+1)/2):
/// pi (1 - (1 + 4u^2)^((1-c)/2)) / (4u^2 (c-1)/2), the numerator the PSD's
/// mass inside the unit disk at B = 2u (SPEC 3).
pub fn ln_m_s(u: f64, c: f64) -> f64 {
    let a = 4.0 * u * u;
    if a < 1e-12 {
        return PI.ln();
    }
    (PI * mass_inside(1.0, 2.0 * u, c) / (0.5 * a * (c - 1.0))).ln()
}

/// ln m_D: m_D = int exp(-(r/beta)^(2p)) 2 pi r dr = pi beta^2 Gamma(1 + 1/p)
/// = beta^2 / N(p), the EPD's mass in the small-slope limit.
pub fn ln_m_d(p: f64, beta: f64) -> f64 {
    2.0 * beta.ln() - norm(p).ln()
}

/// The EPD's slope variance per axis: beta^2 Gamma(2/p) / (2 Gamma(1/p)).
pub fn slope_variance(p: f64, beta: f64) -> f64 {
    0.5 * beta * beta * (ln_gamma(2.0 / p) - ln_gamma(1.0 / p)).exp()
}

/// b's factors: ln m_D and s2 depend on (p, beta) only, the angle terms on
/// (theta, u, s2), so a lookup computes each once per distinct node value.
struct NarrowNdf {
    ln_md: f64,
    s2: f64,
}

impl NarrowNdf {
    fn new(p: f64, beta: f64) -> NarrowNdf {
        NarrowNdf { ln_md: ln_m_d(p, beta), s2: slope_variance(p, beta) }
    }

    /// (ln(1 + 4u^2 sin^2 theta), ln((cos^2 theta + s2)/(1 + s2))).
    fn angle_terms(&self, theta: f64, u: f64) -> (f64, f64) {
        let (sin, cos) = theta.sin_cos();
        ((4.0 * u * u * sin * sin).ln_1p(), ((cos * cos + self.s2) / (1.0 + self.s2)).ln())
    }

    fn b(&self, c: f64, (spread, cos_term): (f64, f64)) -> f64 {
        self.ln_md - 0.5 * (c + 1.0) * spread + cos_term
    }
}

/// b: ln C where the NDF is the narrower lobe, C ~ m_D S(theta).
pub fn narrow_ndf_term(theta: f64, u: f64, c: f64, p: f64, beta: f64) -> f64 {
    let ndf = NarrowNdf::new(p, beta);
    ndf.b(c, ndf.angle_terms(theta, u))
}

/// lambda: near 1 where the diffraction lobe is the narrower, near 0 where the NDF is.
pub fn weight(u: f64, p: f64, beta: f64) -> f64 {
    let ws2 = 1.0 / (1.0 + 4.0 * u * u);
    let wd2 = (beta / (2.0 * p)).powi(2);
    (wd2 / (ws2 + wd2)).powi(2)
}

/// The formula of the decoding, for the manifest's `value_encoding` (every reader implements it).
pub const FORMULA: &str = "stored c_lobe = ln C at the nodes; c_lobe = exp(sum_k w_k (stored_k - t_k) + t_q): w_k and \
    stored_k the multilinear weights and stored values at the 32 corners k of the cell holding the query point q; t = lambda ln m_S(u, c) + (1 - lambda) \
    b(theta_h, u, c, p, beta), t_k at corner k's nodes (its theta_h from its v_theta by the derived axis's inverse at \
    its own u, beta, p), t_q at q; lambda = (wd2 / (ws2 + wd2))^2 at q (the same for every corner), ws2 = 1/(1 + 4u^2), \
    wd2 = (beta/(2p))^2; m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1)), and m_S = pi where 4u^2 < 1e-12; \
    b = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta_h) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p))";

/// C at physical (u, c, p, beta) = `pt` and `theta` from the stored ln C of
/// zh_lobe (`axes`, `values`; `derivation` its angle axis v_theta).
pub fn decode_lobe(axes: &[Axis], values: &ArrayD<f32>, derivation: &Derivation, pt: &[f64], theta: f64) -> Result<f64, DomainError> {
    let (u, c, p, beta) = (pt[0], pt[1], pt[2], pt[3]);
    let lambda = weight(u, p, beta);
    let v = derivation.forward(theta, &[u, beta, p]);
    let corrected = interpolate_with(axes, &values.view(), &[u, c, p, beta, v], |cell| {
        let terms = corner_terms(axes, derivation, cell, lambda);
        move |corner| -terms[corner]
    })?;
    let t_q = lambda * ln_m_s(u, c) + (1.0 - lambda) * narrow_ndf_term(theta, u, c, p, beta);
    Ok((corrected + t_q).exp())
}

/// t at the 32 corners of the cell whose lower node indices are `cell`
/// (corner bit d: the upper node along axis d of u, c, p, beta, v_theta).
/// Of its factors, ln m_S takes 4 (u, c) node pairs, ln m_D and s2 4 (p, beta)
/// pairs (3 ln Gamma each), and the corner's angle 16 (u, p, beta, v_theta):
/// with t at the query point, 15 ln Gamma per lookup instead of 99.
fn corner_terms(axes: &[Axis], derivation: &Derivation, cell: &[usize], lambda: f64) -> [f64; 32] {
    let node = |d: usize, corner: usize| axes[d].nodes[cell[d] + (corner >> d & 1)];
    let ms: [f64; 4] = std::array::from_fn(|k| ln_m_s(node(0, k), node(1, k)));
    let ndf: [NarrowNdf; 4] = std::array::from_fn(|k| NarrowNdf::new(node(2, k << 2), node(3, k << 2)));
    // Indexed by the corner's u, p, beta, v_theta bits (0, 2, 3, 4).
    let angle: [(f64, f64); 16] = std::array::from_fn(|k| {
        let corner = (k & 1) | (k >> 1) << 2;
        let (u, p, beta) = (node(0, corner), node(2, corner), node(3, corner));
        ndf[corner >> 2 & 3].angle_terms(derivation.inverse(node(4, corner), &[u, beta, p]), u)
    });
    std::array::from_fn(|corner| {
        let b = ndf[corner >> 2 & 3].b(node(1, corner), angle[(corner & 1) | (corner >> 2) << 1]);
        lambda * ms[corner & 3] + (1.0 - lambda) * b
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use quadrature::double_exponential::integrate;

    #[test]
    fn m_s_is_the_integral_it_names() {
        for &(u, c) in &[(0.0, 1.02), (0.3, 1.5), (2.0, 2.2), (40.0, 1.02), (100.0, 3.02)] {
            let a = 4.0 * u * u;
            // Split geometrically: the integrand falls by 1e4 within x < 1e-4 at u = 100.
            let edges: Vec<f64> = std::iter::once(0.0).chain((0..=8).rev().map(|k| 10f64.powi(-k))).collect();
            let want = PI * edges.windows(2).map(|w| integrate(|x: f64| (1.0 + a * x).powf(-0.5 * (c + 1.0)), w[0], w[1], 1e-15).integral).sum::<f64>();
            assert!((ln_m_s(u, c) - want.ln()).abs() < 1e-9, "u {u}, c {c}: {} vs {}", ln_m_s(u, c), want.ln());
        }
    }

    #[test]
    fn m_d_and_the_slope_variance_match_the_gaussian_and_exponential_closed_forms() {
        // p = 1: exp(-r^2/beta^2), mass pi beta^2, slope variance beta^2/2 per axis;
        // p = 1/2: exp(-r/beta), mass 2 pi beta^2, variance int r^2 e^(-r/beta) pi r dr / mass = 3 beta^2.
        for beta in [0.005, 0.1, 0.5] {
            let b2 = beta * beta;
            assert!((ln_m_d(1.0, beta) - (PI * b2).ln()).abs() < 1e-12);
            assert!((ln_m_d(0.5, beta) - (2.0 * PI * b2).ln()).abs() < 1e-12);
            assert!((slope_variance(1.0, beta) / (0.5 * b2) - 1.0).abs() < 1e-12);
            assert!((slope_variance(0.5, beta) / (3.0 * b2) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn corner_terms_are_t_at_each_corner_node() {
        // The shared factors must give, bit for bit, t at the corner's own nodes and angle.
        use crate::tables::zh_lobe::{grid, DERIVATION};
        let axes = grid([5, 4, 6, 5, 7]);
        for (cell, lambda) in [([0, 0, 0, 0, 0], 0.3), ([3, 2, 4, 3, 5], 0.9), ([1, 0, 2, 3, 2], 1e-6)] {
            let terms = corner_terms(&axes, &DERIVATION, &cell, lambda);
            for (corner, &got) in terms.iter().enumerate() {
                let [u, c, p, beta, v] = std::array::from_fn(|d| axes[d].nodes[cell[d] + (corner >> d & 1)]);
                let theta = DERIVATION.inverse(v, &[u, beta, p]);
                let want = lambda * ln_m_s(u, c) + (1.0 - lambda) * narrow_ndf_term(theta, u, c, p, beta);
                assert_eq!(got.to_bits(), want.to_bits(), "cell {cell:?} corner {corner}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn the_weight_follows_which_lobe_is_narrower() {
        assert!(weight(100.0, 0.3, 0.5) > 0.99); // diffraction lobe 0.005 wide, EPD ~0.8
        assert!(weight(0.5, 5.0, 0.005) < 1e-6); // EPD 5e-4 wide, diffraction lobe ~0.7
        let w = weight(2.0, 1.0, 2.0 / 17f64.sqrt());
        assert!((w - 0.25).abs() < 1e-12, "{w}"); // equal widths
    }
}
