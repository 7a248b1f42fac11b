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
//!
//! Value encoding `ln_control_variates_tails` (0.6.0) adds the tails: beyond
//! both lobes' cores the convolution of two heavy-tailed lobes is the sum of
//! each one's tail times the other's mass, C ~ m_S D + m_D S, so
//!   t = (1 - w) (lambda ln m_S + (1 - lambda) b) + w logaddexp(ln m_S + ln D(theta_eff), b),
//! ln D the EPD's shape at theta_eff^2 = theta^2 + 1/(4 (1 + 4u^2)) (its cusp
//! at small p smoothed by the diffraction core), and w, like lambda, taken at
//! the query point: rising from v_theta = 0.2 to 0.5, gone at the EPD's
//! grazing peak (small p, large beta: there m_S D is not C even beyond the
//! cores) and for p >= 2 (`tail_weight`). A weight constant over the corners makes the error the same
//! blend of the two decodings' errors (`cargo run --example zh_lobe_lab`:
//! bench probes p99 2.49 % -> 1.68 %, manifest probes 3.10 % -> 2.17 %).
//!
//! Value encoding `ln_control_variates_epd` (0.7.0) puts the EPD's own shape
//! into the core term as well: mu = lambda^2 smoothstep(p, 0.3, 0.5) of the
//! weight lambda of ln m_S goes to logaddexp(ln m_S + ln D(theta_eff), b'),
//! b' = b with sin^2 theta + sig2 in S's spread, sig2 = 2 s2 / (1 + 2 s2): the
//! K-correlation's tail over the EPD's mass, taken at the EPD's rms angle
//! (lab candidate `blend`; p99 2.17 -> 2.03 % on the manifest's probes, 2.28
//! -> 1.68 % drawn uniformly in u, c, p, beta; max never higher).

use crate::axis::{Axis, DomainError};
use crate::derived::{Derivation, ValueEncoding as Encoding};
use crate::interp::interpolate_with;
use special::Gamma;
use ndarray::ArrayD;
use std::f64::consts::{FRAC_PI_2, PI};

/// ln m_S: m_S = pi int_0^1 (1 + 4u^2 x)^(-(c+1)/2) dx, the projected solid
/// angle integral of the K-correlation lobe (1 + 4u^2 sin^2)^(-(c+1)/2):
/// pi (1 - (1 + 4u^2)^((1-c)/2)) / (4u^2 (c-1)/2), the numerator the PSD's
/// mass inside the unit disk at B = 2u (SPEC 3).
pub fn ln_m_s(u: f64, c: f64) -> f64 {
    let a = 4.0 * u * u;
    if a < 1e-12 {
        return PI.ln();
    }
    // 1 - (1 + 4u^2)^((1-c)/2) with expm1/log1p, accurate as c -> 1 and for small u.
    let mass_inside = -(0.5 * (1.0 - c) * a.ln_1p()).exp_m1();
    (PI * mass_inside / (0.5 * a * (c - 1.0))).ln()
}

/// ln m_D: m_D = int exp(-(r/beta)^(2p)) 2 pi r dr = pi beta^2 Gamma(1 + 1/p)
/// = beta^2 p^-1 pi Gamma(1/p), the EPD's mass in the small-slope limit.
pub fn ln_m_d(p: f64, beta: f64) -> f64 {
    2.0 * beta.ln() + PI.ln() + ln_gamma(1.0 / p) - p.ln()
}

/// The EPD's slope variance per axis: beta^2 Gamma(2/p) / (2 Gamma(1/p)).
pub fn slope_variance(p: f64, beta: f64) -> f64 {
    0.5 * beta * beta * (ln_gamma(2.0 / p) - ln_gamma(1.0 / p)).exp()
}

/// ln |Gamma(x)|.
fn ln_gamma(x: f64) -> f64 {
    Gamma::ln_gamma(x).0
}

/// b's factors: ln m_D and s2 depend on (p, beta) only, the angle terms on
/// (theta, u, s2), so a lookup computes each once per distinct node value.
struct NarrowNdf {
    ln_md: f64,
    s2: f64,
}

/// b's and b''s terms at one angle: ln(1 + 4u^2 sin^2 theta), ln(1 + 4u^2
/// (sin^2 theta + sig2)) and ln((cos^2 theta + s2)/(1 + s2)).
#[derive(Clone, Copy)]
struct AngleTerms {
    spread: f64,
    spread_rms: f64,
    cos_term: f64,
}

impl NarrowNdf {
    fn new(p: f64, beta: f64) -> NarrowNdf {
        NarrowNdf { ln_md: ln_m_d(p, beta), s2: slope_variance(p, beta) }
    }

    /// The angle terms; b' (`spread_rms`) only when `rms` (the EPD core term has weight).
    fn angle_terms(&self, theta: f64, u: f64, rms: bool) -> AngleTerms {
        let (sin, cos) = theta.sin_cos();
        let a = 4.0 * u * u;
        let spread_rms = if rms { (a * (sin * sin + 2.0 * self.s2 / (1.0 + 2.0 * self.s2))).ln_1p() } else { 0.0 };
        AngleTerms { spread: (a * sin * sin).ln_1p(), spread_rms, cos_term: ((cos * cos + self.s2) / (1.0 + self.s2)).ln() }
    }

    /// (b, b') at angle terms `at`.
    fn b(&self, c: f64, at: AngleTerms) -> (f64, f64) {
        let k = 0.5 * (c + 1.0);
        (self.ln_md - k * at.spread + at.cos_term, self.ln_md - k * at.spread_rms + at.cos_term)
    }
}

/// b: ln C where the NDF is the narrower lobe, C ~ m_D S(theta).
pub fn narrow_ndf_term(theta: f64, u: f64, c: f64, p: f64, beta: f64) -> f64 {
    let ndf = NarrowNdf::new(p, beta);
    ndf.b(c, ndf.angle_terms(theta, u, false)).0
}

/// lambda: near 1 where the diffraction lobe is the narrower, near 0 where the NDF is.
pub fn weight(u: f64, p: f64, beta: f64) -> f64 {
    let ws2 = 1.0 / (1.0 + 4.0 * u * u);
    let wd2 = (beta / (2.0 * p)).powi(2);
    (wd2 / (ws2 + wd2)).powi(2)
}

/// ln D(theta_eff) = -(tan theta_eff / beta)^(2p) - 4 ln cos theta_eff, the
/// EPD's shape at theta_eff = min(sqrt(theta^2 + 1/(4 (1 + 4u^2))), pi/2):
/// its cusp at theta = 0 for small p smoothed by the diffraction core (cos
/// as sin(pi/2 - theta_eff), at least 1e-300, so the horizon stays finite).
pub fn ln_d_smoothed(theta: f64, u: f64, p: f64, beta: f64) -> f64 {
    let th = (theta * theta + 0.25 / (1.0 + 4.0 * u * u)).sqrt().min(FRAC_PI_2);
    -(th.tan() / beta).powf(2.0 * p) - 4.0 * (FRAC_PI_2 - th).sin().max(1e-300).ln()
}

/// ln(e^a + e^b), b finite.
pub fn logaddexp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    m + ((a - m).exp() + (b - m).exp()).ln()
}

/// 3x^2 - 2x^3 of x = (y - from) / (to - from) clamped to [0, 1].
pub fn smoothstep(y: f64, from: f64, to: f64) -> f64 {
    let x = ((y - from) / (to - from)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// g = -2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), ln D at tan theta = beta
/// (2/p)^(1/(2p)), where D's two factors balance for tan theta >> 1: the
/// EPD's grazing peak where it has one (small p, large beta), and at least
/// -2/p otherwise.
pub fn epd_grazing_peak(p: f64, beta: f64) -> f64 {
    -2.0 / p + 2.0 * (beta * beta * (2.0 / p).powf(1.0 / p)).ln_1p()
}

/// w, the weight of the tail term at stored angle `v` (v_theta): rising from
/// v = 0.2 to 0.5, times 1 - smoothstep(g, -4, -1), g the EPD's grazing peak
/// (`epd_grazing_peak`; there m_S D is not C even beyond the cores: max
/// 17 % -> 49 % without this factor), so the term also fades out from
/// p = 0.5 to 2, where g >= -2/p (and where it left the p99 as it was and
/// raised the relative L2 max 1.7 -> 2.6 %).
pub fn tail_weight(v: f64, p: f64, beta: f64) -> f64 {
    smoothstep(v, 0.2, 0.5) * (1.0 - smoothstep(epd_grazing_peak(p, beta), -4.0, -1.0))
}

/// The formula of the decoding `ln_control_variates` (0.5.0), for the manifest's `value_encoding`.
pub const FORMULA: &str = "stored c_lobe = ln C at the nodes; c_lobe = exp(sum_k w_k (stored_k - t_k) + t_q): w_k and \
    stored_k the multilinear weights and stored values at the 32 corners k of the cell holding the query point q; t = lambda ln m_S(u, c) + (1 - lambda) \
    b(theta_h, u, c, p, beta), t_k at corner k's nodes (its theta_h from its v_theta by the derived axis's inverse at \
    its own u, beta, p), t_q at q; lambda = (wd2 / (ws2 + wd2))^2 at q (the same for every corner), ws2 = 1/(1 + 4u^2), \
    wd2 = (beta/(2p))^2; m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1)), and m_S = pi where 4u^2 < 1e-12; \
    b = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta_h) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p))";

/// The formula of the decoding `ln_control_variates_tails` (0.6.0): the above with the tail term.
pub const FORMULA_TAILS: &str = "stored c_lobe = ln C at the nodes; c_lobe = exp(sum_k w_k (stored_k - t_k) + t_q): w_k and \
    stored_k the multilinear weights and stored values at the 32 corners k of the cell holding the query point q; \
    t = (1 - w) (lambda ln m_S(u, c) + (1 - lambda) b(theta_h, u, c, p, beta)) + w logaddexp(ln m_S(u, c) + ln D(theta_h, u, p, beta), \
    b(theta_h, u, c, p, beta)), logaddexp(x, y) = m + ln(exp(x - m) + exp(y - m)), m = max(x, y); t_k at corner k's \
    nodes (its theta_h from its v_theta by the derived axis's inverse at its own u, beta, p), t_q at q; lambda and w at q \
    (the same for every corner): lambda = (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2; \
    w = smoothstep(v_theta of q, 0.2, 0.5) (1 - smoothstep(-2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), -4, -1)), \
    smoothstep(y, a, b) = 3x^2 - 2x^3 with x = (y - a)/(b - a) clamped to [0, 1]; \
    m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1)), and m_S = pi where 4u^2 < 1e-12; \
    b = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta_h) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p)); ln D = -(tan e / beta)^(2p) - 4 ln(max(sin(pi/2 - e), 1e-300)), \
    e = min(sqrt(theta_h^2 + 1/(4 (1 + 4u^2))), pi/2)";

/// The formula of the decoding `ln_control_variates_epd` (0.7.0): the above with the EPD's shape in the core term.
pub const FORMULA_EPD: &str = "stored c_lobe = ln C at the nodes; c_lobe = exp(sum_k w_k (stored_k - t_k) + t_q): w_k and \
    stored_k the multilinear weights and stored values at the 32 corners k of the cell holding the query point q; \
    t = (1 - w) (mu logaddexp(ln m_S(u, c) + ln D(theta_h, u, p, beta), b'(theta_h, u, c, p, beta)) + (lambda - mu) ln m_S(u, c) \
    + (1 - lambda) b(theta_h, u, c, p, beta)) + w logaddexp(ln m_S(u, c) + ln D(theta_h, u, p, beta), b(theta_h, u, c, p, beta)), \
    logaddexp(x, y) = m + ln(exp(x - m) + exp(y - m)), m = max(x, y); t_k at corner k's \
    nodes (its theta_h from its v_theta by the derived axis's inverse at its own u, beta, p), t_q at q; lambda, mu and w at q \
    (the same for every corner): lambda = (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2; \
    mu = lambda^2 smoothstep(p, 0.3, 0.5); \
    w = smoothstep(v_theta of q, 0.2, 0.5) (1 - smoothstep(-2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), -4, -1)), \
    smoothstep(y, a, b) = 3x^2 - 2x^3 with x = (y - a)/(b - a) clamped to [0, 1]; \
    m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1)), and m_S = pi where 4u^2 < 1e-12; \
    b = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta_h) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    b' = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 (sin^2 theta_h + 2 s2/(1 + 2 s2))) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p)); ln D = -(tan e / beta)^(2p) - 4 ln(max(sin(pi/2 - e), 1e-300)), \
    e = min(sqrt(theta_h^2 + 1/(4 (1 + 4u^2))), pi/2)";

/// A query point's weights, the same at every corner: lambda of ln m_S (1 -
/// lambda of b), mu (`epd`) of lambda's share going to the EPD's shape, w
/// (`tail`) of the tail term; mu and w are 0 in the encodings without them.
#[derive(Clone, Copy, Debug)]
pub struct Weights {
    pub lambda: f64,
    pub epd: f64,
    pub tail: f64,
}

impl Weights {
    /// The weights of value encoding `kind` at (u, p, beta) and stored angle `v`.
    pub fn of(kind: Encoding, u: f64, p: f64, beta: f64, v: f64) -> Weights {
        let lambda = weight(u, p, beta);
        let (epd, tail) = match kind {
            Encoding::LnControlVariatesEpd => (lambda * lambda * smoothstep(p, 0.3, 0.5), tail_weight(v, p, beta)),
            Encoding::LnControlVariatesTails => (0.0, tail_weight(v, p, beta)),
            _ => (0.0, 0.0),
        };
        Weights { lambda, epd, tail }
    }

    /// t from ln m_S, (b, b') and (where mu or w > 0) ln D at one node or the query point.
    fn t(self, ln_ms: f64, (b, b_rms): (f64, f64), ln_d: impl FnOnce() -> f64) -> f64 {
        if self.epd == 0.0 && self.tail == 0.0 {
            return self.lambda * ln_ms + (1.0 - self.lambda) * b;
        }
        let narrow = ln_ms + ln_d();
        let core = if self.epd == 0.0 {
            self.lambda * ln_ms + (1.0 - self.lambda) * b
        } else {
            self.epd * logaddexp(narrow, b_rms) + (self.lambda - self.epd) * ln_ms + (1.0 - self.lambda) * b
        };
        if self.tail == 0.0 {
            return core;
        }
        (1.0 - self.tail) * core + self.tail * logaddexp(narrow, b)
    }
}

/// C at physical (u, c, p, beta) = `pt` and `theta` from the stored ln C of
/// zh_lobe (`axes`, `values`; `derivation` its angle axis v_theta), decoded
/// as value encoding `kind` says (one of the `ln_control_variates*`).
pub fn decode_lobe(axes: &[Axis], values: &ArrayD<f32>, derivation: &Derivation, kind: Encoding, pt: &[f64], theta: f64) -> Result<f64, DomainError> {
    let (u, c, p, beta) = (pt[0], pt[1], pt[2], pt[3]);
    let v = derivation.forward(theta, &[u, beta, p]);
    let weights = Weights::of(kind, u, p, beta, v);
    let corrected = interpolate_with(axes, &values.view(), &[u, c, p, beta, v], |cell| {
        let terms = corner_terms(axes, derivation, cell, weights);
        move |corner| -terms[corner]
    })?;
    Ok((corrected + control_variate(theta, u, c, p, beta, weights)).exp())
}

/// t at (theta, u, c, p, beta) for the weights of a query point.
pub fn control_variate(theta: f64, u: f64, c: f64, p: f64, beta: f64, weights: Weights) -> f64 {
    let ndf = NarrowNdf::new(p, beta);
    let b = ndf.b(c, ndf.angle_terms(theta, u, weights.epd > 0.0));
    weights.t(ln_m_s(u, c), b, || ln_d_smoothed(theta, u, p, beta))
}

/// t at the 32 corners of the cell whose lower node indices are `cell`
/// (corner bit d: the upper node along axis d of u, c, p, beta, v_theta).
/// Of its factors, ln m_S takes 4 (u, c) node pairs, ln m_D and s2 4 (p, beta)
/// pairs (3 ln Gamma each), and the corner's angle and ln D 16 (u, p, beta, v_theta):
/// with t at the query point, 15 ln Gamma per lookup instead of 99.
fn corner_terms(axes: &[Axis], derivation: &Derivation, cell: &[usize], weights: Weights) -> [f64; 32] {
    let node = |d: usize, corner: usize| axes[d].nodes[cell[d] + (corner >> d & 1)];
    let ms: [f64; 4] = std::array::from_fn(|k| ln_m_s(node(0, k), node(1, k)));
    let ndf: [NarrowNdf; 4] = std::array::from_fn(|k| NarrowNdf::new(node(2, k << 2), node(3, k << 2)));
    let shaped = weights.epd > 0.0 || weights.tail > 0.0;
    // Indexed by the corner's u, p, beta, v_theta bits (0, 2, 3, 4): the angle terms and ln D (when mu or w > 0).
    let angle: [(AngleTerms, f64); 16] = std::array::from_fn(|k| {
        let corner = (k & 1) | (k >> 1) << 2;
        let (u, p, beta) = (node(0, corner), node(2, corner), node(3, corner));
        let theta = derivation.inverse(node(4, corner), &[u, beta, p]);
        let ln_d = if shaped { ln_d_smoothed(theta, u, p, beta) } else { 0.0 };
        (ndf[corner >> 2 & 3].angle_terms(theta, u, weights.epd > 0.0), ln_d)
    });
    std::array::from_fn(|corner| {
        let (terms, ln_d) = angle[(corner & 1) | (corner >> 2) << 1];
        let b = ndf[corner >> 2 & 3].b(node(1, corner), terms);
        weights.t(ms[corner & 3], b, || ln_d)
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
    fn the_weights_of_each_encoding() {
        // mu = lambda^2 smoothstep(p, 0.3, 0.5) only in ln_control_variates_epd, w only with the tail term.
        let (u, beta, v) = (3.0, 0.2, 0.6);
        for p in [0.25, 0.4, 1.5] {
            let lambda = weight(u, p, beta);
            let epd = Weights::of(Encoding::LnControlVariatesEpd, u, p, beta, v);
            let want_mu = lambda * lambda * smoothstep(p, 0.3, 0.5);
            assert!(epd.lambda == lambda && epd.epd == want_mu && epd.tail == tail_weight(v, p, beta), "p {p}: {epd:?}");
            let tails = Weights::of(Encoding::LnControlVariatesTails, u, p, beta, v);
            assert!(tails.epd == 0.0 && tails.tail == epd.tail);
            let core = Weights::of(Encoding::LnControlVariates, u, p, beta, v);
            assert!(core.epd == 0.0 && core.tail == 0.0);
        }
        assert_eq!(Weights::of(Encoding::LnControlVariatesEpd, u, 0.25, beta, v).epd, 0.0);
        let mid = Weights::of(Encoding::LnControlVariatesEpd, u, 0.4, beta, v);
        assert!((mid.epd - 0.5 * mid.lambda * mid.lambda).abs() < 1e-15);
    }

    #[test]
    fn the_weight_follows_which_lobe_is_narrower() {
        assert!(weight(100.0, 0.3, 0.5) > 0.99); // diffraction lobe 0.005 wide, EPD ~0.8
        assert!(weight(0.5, 5.0, 0.005) < 1e-6); // EPD 5e-4 wide, diffraction lobe ~0.7
        let w = weight(2.0, 1.0, 2.0 / 17f64.sqrt());
        assert!((w - 0.25).abs() < 1e-12, "{w}"); // equal widths
    }

}
