//! zh_lobe's control variates (docs/maths.md section 4b, docs/file_contract.md).
//!
//! The table stores ln C at the nodes. In the two limits of C = S * D the
//! parameter dependence of ln C is known:
//! - diffraction lobe the narrower (w_S << w_D): C ~ m_S(u, c) D, so ln C
//!   carries ln m_S, curved in ln(1 + 4u^2) and in c;
//! - NDF the narrower: C ~ m_D(p, beta) S(theta), so ln C carries
//!   b = ln m_D - (c+1)/2 ln(1 + 4u^2 sin^2 theta) + ln((cos^2 theta + s2)/(1 + s2)),
//!   S's t^2 factor smoothed by the NDF's slope variance s2;
//! - beyond both lobes' cores the convolution of two heavy-tailed lobes is the
//!   sum of each one's tail times the other's mass, C ~ m_S D + m_D S:
//!   `tail` = logaddexp(ln m_S + ln D(theta_eff), b);
//! - for p between 0.3 and 0.5 the EPD's own shape enters the core:
//!   `epd_core` = logaddexp(ln m_S + ln D(theta_eff), b'), b' = b with
//!   sin^2 theta + 2 s2 / (1 + 2 s2) in S's spread.
//!
//! The decoding is linear in these four terms t_j with weights alpha_j taken
//! at the query point q only:
//!   ln C(q) = I[ln C](q) + sum_j alpha_j(q) (t_j(q) - I[t_j](q)),
//! I the multilinear interpolation. The build stores t_j at the nodes (values
//! `cv_<term>`), so a reader interpolates five datasets with the same cell
//! weights and adds the terms at q (`correction`). A weight only scales its
//! term's own interpolation error, which the term then cancels where its
//! limit holds (docs/zh_lobe.md: p99 4.3 % -> 2.03 % against exp of the
//! interpolated ln C).

use serde::{Deserialize, Serialize};
use special::Gamma;
use std::f64::consts::{FRAC_PI_2, PI};

/// One control variate of zh_lobe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// ln m_S(u, c).
    LnMS,
    /// b(theta, u, c, p, beta).
    B,
    /// logaddexp(ln m_S + ln D(theta_eff), b').
    EpdCore,
    /// logaddexp(ln m_S + ln D(theta_eff), b).
    Tail,
}

impl Term {
    pub const ALL: [Term; 4] = [Term::LnMS, Term::B, Term::EpdCore, Term::Tail];

    /// The name of the dataset holding the term at the nodes.
    pub fn values_name(self) -> String {
        let tagged = serde_json::to_value(self).expect("a term serialises");
        format!("cv_{}", tagged.as_str().expect("a unit variant"))
    }
}

/// The parameters of the convolved lobe, in the order of zh_lobe's axes
/// everywhere: the diffraction lobe's u and c, the EPD's p and beta.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeParams {
    pub u: f64,
    pub c: f64,
    pub p: f64,
    pub beta: f64,
}

impl LobeParams {
    /// The inputs of zh_lobe's derived angle (`Derivation::AnchoredLobeAngle`): (u, p, beta).
    pub fn angle_inputs(&self) -> [f64; 3] {
        [self.u, self.p, self.beta]
    }
}

/// ln m_S: m_S = pi int_0^1 (1 + 4u^2 x)^(-(c+1)/2) dx, the projected solid
/// angle integral of the K-correlation lobe (1 + 4u^2 sin^2)^(-(c+1)/2):
/// pi (1 - (1 + 4u^2)^((1-c)/2)) / (4u^2 (c-1)/2).
pub fn ln_m_s(u: f64, c: f64) -> f64 {
    let a = 4.0 * u * u;
    if a < 1e-12 {
        return PI.ln();
    }
    // 1 - (1 + 4u^2)^((1-c)/2) with expm1/log1p, accurate as c -> 1 and for small u.
    let mass_inside = -(0.5 * (1.0 - c) * a.ln_1p()).exp_m1();
    (PI * mass_inside / (0.5 * a * (c - 1.0))).ln()
}

/// ln m_D: m_D = int exp(-(r/beta)^(2p)) 2 pi r dr = pi beta^2 Gamma(1 + 1/p),
/// the EPD's mass in the small-slope limit.
pub fn ln_m_d(p: f64, beta: f64) -> f64 {
    2.0 * beta.ln() + PI.ln() + ln_gamma(1.0 / p) - p.ln()
}

/// The EPD's slope variance per axis: beta^2 Gamma(2/p) / (2 Gamma(1/p)).
pub fn slope_variance(p: f64, beta: f64) -> f64 {
    0.5 * beta * beta * (ln_gamma(2.0 / p) - ln_gamma(1.0 / p)).exp()
}

fn ln_gamma(x: f64) -> f64 {
    Gamma::ln_gamma(x).0
}

/// lambda: near 1 where the diffraction lobe is the narrower, near 0 where the NDF is:
/// (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2.
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
/// (there m_S D is not C even beyond the cores), so the term also fades out
/// from p = 0.5 to 2, where g >= -2/p.
pub fn tail_weight(v: f64, p: f64, beta: f64) -> f64 {
    smoothstep(v, 0.2, 0.5) * (1.0 - smoothstep(epd_grazing_peak(p, beta), -4.0, -1.0))
}

/// The weights alpha_j of `Term::ALL` at a query point (u, p, beta) and
/// stored angle v: (1 - w)(lambda - mu), (1 - w)(1 - lambda), (1 - w) mu and
/// w, with mu = lambda^2 smoothstep(p, 0.3, 0.5) and w = `tail_weight`.
pub fn weights(u: f64, p: f64, beta: f64, v: f64) -> [f64; 4] {
    let lambda = weight(u, p, beta);
    let mu = lambda * lambda * smoothstep(p, 0.3, 0.5);
    let w = tail_weight(v, p, beta);
    [(1.0 - w) * (lambda - mu), (1.0 - w) * (1.0 - lambda), (1.0 - w) * mu, w]
}

/// The terms t_j of `Term::ALL` at angle `theta`, those whose `wanted` is false left 0.
pub fn terms(theta: f64, x: &LobeParams, wanted: [bool; 4]) -> [f64; 4] {
    LobeTerms::new(x).at(theta, wanted)
}

/// The factors of the terms that do not depend on the angle (3 ln Gamma), for
/// the terms at many angles of one parameter point.
pub struct LobeTerms {
    x: LobeParams,
    ln_ms: f64,
    ln_md: f64,
    s2: f64,
}

impl LobeTerms {
    pub fn new(x: &LobeParams) -> LobeTerms {
        LobeTerms { x: *x, ln_ms: ln_m_s(x.u, x.c), ln_md: ln_m_d(x.p, x.beta), s2: slope_variance(x.p, x.beta) }
    }

    /// The terms t_j of `Term::ALL` at angle `theta`, those whose `wanted` is false left 0.
    pub fn at(&self, theta: f64, wanted: [bool; 4]) -> [f64; 4] {
        let LobeParams { u, c, p, beta } = self.x;
        let (ms, s2) = (self.ln_ms, self.s2);
        let (sin, cos) = theta.sin_cos();
        let a = 4.0 * u * u;
        let k = 0.5 * (c + 1.0);
        let base = self.ln_md + ((cos * cos + s2) / (1.0 + s2)).ln();
        let b = base - k * (a * sin * sin).ln_1p();
        let narrow = if wanted[2] || wanted[3] { ms + ln_d_smoothed(theta, u, p, beta) } else { 0.0 };
        let epd_core = if wanted[2] {
            logaddexp(narrow, base - k * (a * (sin * sin + 2.0 * s2 / (1.0 + 2.0 * s2))).ln_1p())
        } else {
            0.0
        };
        let tail = if wanted[3] { logaddexp(narrow, b) } else { 0.0 };
        [ms, b, epd_core, tail]
    }
}

/// sum_j alpha_j (t_j - interpolated_j): what the control variates add to
/// the interpolated ln C at (`theta`, `x`) (stored angle `v`), given the terms
/// interpolated there in the order of `Term::ALL`. Terms of zero weight are
/// not computed.
pub fn correction(theta: f64, x: &LobeParams, v: f64, interpolated: [f64; 4]) -> f64 {
    let alpha = weights(x.u, x.p, x.beta, v);
    let t = terms(theta, x, alpha.map(|a| a != 0.0));
    (0..4).filter(|&j| alpha[j] != 0.0).map(|j| alpha[j] * (t[j] - interpolated[j])).sum()
}

/// The decoding as the manifest states it.
pub const FORMULA: &str = "stored = ln C at the nodes; C(q) = exp(I[stored](q) + sum_j alpha_j(q) (t_j(q) - I[cv_j](q))), \
    I the multilinear interpolation in the encoded coordinates, cv_j the stored values of term j at the nodes, t_j(q) the term at \
    the query point q = (theta_h, u, c, p, beta); terms t = [ln_m_s, b, epd_core, tail] = [ln m_S, b, logaddexp(ln m_S + ln D, b'), \
    logaddexp(ln m_S + ln D, b)], weights alpha = [(1 - w)(lambda - mu), (1 - w)(1 - lambda), (1 - w) mu, w]; \
    lambda = (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2; mu = lambda^2 smoothstep(p, 0.3, 0.5); \
    w = smoothstep(v_theta of q, 0.2, 0.5) (1 - smoothstep(-2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), -4, -1)), \
    smoothstep(y, a, b) = 3x^2 - 2x^3 with x = (y - a)/(b - a) clamped to [0, 1]; logaddexp(x, y) = m + ln(exp(x - m) + exp(y - m)), \
    m = max(x, y); m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1)), and m_S = pi where 4u^2 < 1e-12; \
    b = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta_h) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    b' = ln(pi beta^2 Gamma(1 + 1/p)) - (c+1)/2 ln(1 + 4u^2 (sin^2 theta_h + 2 s2/(1 + 2 s2))) + ln((cos^2 theta_h + s2)/(1 + s2)), \
    s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p)); ln D = -(tan e / beta)^(2p) - 4 ln(max(sin(pi/2 - e), 1e-300)), \
    e = min(sqrt(theta_h^2 + 1/(4 (1 + 4u^2))), pi/2); terms of zero weight may be skipped";

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
            let want = PI
                * edges
                    .windows(2)
                    .map(|w| integrate(|x: f64| (1.0 + a * x).powf(-0.5 * (c + 1.0)), w[0], w[1], 1e-15).integral)
                    .sum::<f64>();
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
    fn the_terms_are_their_formulas() {
        // Each term from its definition, written out independently of `terms`.
        for &(theta, u, c, p, beta) in
            &[(0.01f64, 0.0, 1.02, 0.2, 0.005), (0.4, 3.0, 2.0, 0.4, 0.2), (1.5, 100.0, 3.02, 5.0, 0.5)]
        {
            let x = LobeParams { u, c, p, beta };
            let s2 = slope_variance(p, beta);
            let spread = |sin2: f64| (1.0 + 4.0 * u * u * sin2).ln();
            let cos_term = ((theta.cos().powi(2) + s2) / (1.0 + s2)).ln();
            let b = ln_m_d(p, beta) - 0.5 * (c + 1.0) * spread(theta.sin().powi(2)) + cos_term;
            let b_rms = ln_m_d(p, beta) - 0.5 * (c + 1.0) * spread(theta.sin().powi(2) + 2.0 * s2 / (1.0 + 2.0 * s2))
                + cos_term;
            let d = (ln_m_s(u, c) + ln_d_smoothed(theta, u, p, beta)).exp();
            let want = [ln_m_s(u, c), b, (d + b_rms.exp()).ln(), (d + b.exp()).ln()];
            let got = terms(theta, &x, [true; 4]);
            for j in 0..4 {
                assert!(
                    (got[j] - want[j]).abs() <= 1e-12 * want[j].abs().max(1.0),
                    "{x:?} term {j}: {} vs {}",
                    got[j],
                    want[j]
                );
            }
            assert_eq!(terms(theta, &x, [true, true, false, false])[2..], [0.0, 0.0]);
        }
    }

    #[test]
    fn the_weights_split_lambda_between_the_core_terms_and_w_to_the_tail() {
        let (u, beta, v) = (3.0, 0.2, 0.6);
        for p in [0.25, 0.4, 1.5] {
            let (lambda, w) = (weight(u, p, beta), tail_weight(v, p, beta));
            let mu = lambda * lambda * smoothstep(p, 0.3, 0.5);
            let a = weights(u, p, beta, v);
            assert_eq!(a, [(1.0 - w) * (lambda - mu), (1.0 - w) * (1.0 - lambda), (1.0 - w) * mu, w]);
            // The weights of a point sum to one: the decoding is exact for a constant shift of every term.
            assert!((a.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
        assert_eq!(weights(u, 0.25, beta, v)[2], 0.0); // no EPD core term below p = 0.3
        assert_eq!(weights(u, 0.4, beta, 0.1)[3], 0.0); // no tail term inside the cores
    }

    #[test]
    fn the_correction_is_zero_at_the_interpolated_terms_and_skips_zero_weights() {
        let (theta, x) = (0.3, LobeParams { u: 2.0, c: 1.5, p: 0.25, beta: 0.1 });
        let v = 0.1; // w = 0 and mu = 0: only ln m_S and b count
        let t = terms(theta, &x, [true; 4]);
        assert_eq!(correction(theta, &x, v, t), 0.0);
        let a = weights(x.u, x.p, x.beta, v);
        let shifted = [t[0] - 1.0, t[1] - 2.0, f64::NAN, f64::NAN];
        assert!((correction(theta, &x, v, shifted) - (a[0] + 2.0 * a[1])).abs() < 1e-12);
    }

    #[test]
    fn the_weight_follows_which_lobe_is_narrower() {
        assert!(weight(100.0, 0.3, 0.5) > 0.99); // diffraction lobe 0.005 wide, EPD ~0.8
        assert!(weight(0.5, 5.0, 0.005) < 1e-6); // EPD 5e-4 wide, diffraction lobe ~0.7
        let w = weight(2.0, 1.0, 2.0 / 17f64.sqrt());
        assert!((w - 0.25).abs() < 1e-12, "{w}"); // equal widths
    }

    #[test]
    fn term_datasets_are_named_cv_and_the_term() {
        let names: Vec<String> = Term::ALL.iter().map(|t| t.values_name()).collect();
        assert_eq!(names, ["cv_ln_m_s", "cv_b", "cv_epd_core", "cv_tail"]);
    }
}
