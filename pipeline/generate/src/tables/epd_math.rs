//! The Exponential Power Distribution (docs/maths.md section 1) and the Smith
//! shadowing of its slope density (docs/maths.md section 2).

use crate::numerics::quadrature::{self, Integral};
use crate::numerics::special::{acosh, ln_gamma, x_minus_atan};
use std::f64::consts::{FRAC_PI_2, LN_2, PI};

/// Relative tolerance of the Lambda quadrature, applied to the G7-based error
/// estimate. The K15 values kept are far more accurate: over the paper grid
/// plus 1,400 points down to p = 0.05, the worst deviation from a 1e-15-tolerance
/// evaluation is 8e-14 (1e-12 gives the same; 1e-9 gives 2e-13).
pub const LAMBDA_REL_TOL: f64 = 1e-10;

/// N(p) = p / (pi Gamma(1/p)), the normalisation of the EPD; N(0) = 0.
pub fn norm(p: f64) -> f64 {
    if p == 0.0 {
        return 0.0;
    }
    (p.ln() - ln_gamma(1.0 / p)).exp() / PI
}

/// M1(p) = Gamma(3/(2p)) / (pi Gamma(1/p)): Lambda(p, a) ~ a M1(p) - 1/2 as a -> inf.
pub fn m1(p: f64) -> f64 {
    (ln_gamma(1.5 / p) - ln_gamma(1.0 / p)).exp() / PI
}

/// y = acosh(exp(ln_ratio)) without overflow; 0 when the ratio is below 1.
fn y_of_ln_ratio(ln_ratio: f64) -> f64 {
    if ln_ratio <= 0.0 {
        0.0
    } else if ln_ratio > 18.0 {
        ln_ratio + LN_2 // acosh(z) = ln(2z) + O(z^-2)
    } else {
        acosh(ln_ratio.exp())
    }
}

/// Smith's Lambda(p, a) for the EPD slope density with beta = 1, by the
/// one-dimensional form of docs/maths.md section 2:
///
///   Lambda = 2 N(p) int_mu^inf (sqrt(rho^2 - mu^2)/mu - acos(mu/rho)) exp(-rho^(2p)) rho drho,
///
/// with mu = 1/a, integrated in y where rho = mu cosh(y). Then
/// sqrt(rho^2 - mu^2)/mu - acos(mu/rho) = sinh(y) - atan(sinh(y)) and
/// rho drho = rho * mu sinh(y) dy: the integrand is analytic in y (the
/// (rho - mu)^(3/2) behaviour at rho = mu disappears), and y ~ ln(rho) far from
/// mu, which follows the heavy tail of small p (rho up to 1e20 at p = 0.05)
/// as well as a logarithmic variable (equivalent to integrating in
/// t = rho^(2p) there). Breakpoints at rho = 1 (where exp(-rho^(2p)) drops
/// sharply for large p) and at the peak of the mass.
pub fn lambda_integral(p: f64, a: f64) -> Integral {
    lambda_integral_tol(p, a, LAMBDA_REL_TOL)
}

/// `lambda_integral` at a chosen relative tolerance (for references).
pub fn lambda_integral_tol(p: f64, a: f64, rel_tol: f64) -> Integral {
    let exact = |value| Integral { value, error: 0.0, evaluations: 0, converged: true };
    if a == 0.0 {
        return exact(0.0);
    }
    if a.is_infinite() {
        return exact(f64::INFINITY);
    }
    let two_p = 2.0 * p;
    let ln_mu = -a.ln();
    let mu = 1.0 / a;
    // t0 = mu^(2p): the integrand is below exp(-t0); beyond 740 Lambda underflows.
    let t0 = (two_p * ln_mu).exp();
    if t0 > 740.0 {
        return exact(0.0);
    }
    // Far from rho = mu the integrand behaves as t^k exp(-t) dt with t = rho^(2p),
    // k = 3/(2p) - 1: past t_hi it is below exp(-50) of its peak.
    let k = (1.5 / p - 1.0).max(0.0);
    let t_hi = t0.max(k) + 50.0 + 8.0 * k.sqrt();
    let ln_rho_hi = t_hi.ln() / two_p;
    // Near rho = 0 the integrand is ~ rho^3 / mu, i.e. t^(3/(2p) - 1) dt: the mass
    // below t_lo is t_lo^(3/(2p)) / Gamma(3/(2p) + 1) of the total; make it < e^-39.
    let m = 1.5 / p;
    let ln_rho_lo = (ln_gamma(m + 1.0) - 39.0) / m / two_p;
    let ln_rho_peak = m.ln() / two_p;
    let y_hi = y_of_ln_ratio(ln_rho_hi - ln_mu);
    // The integrand overflows f64 before y_hi (cosh y past y = 354, rho q (s - atan s) ~
    // mu^2 e^(3y) / 8 sooner) when p is small (heavy tails, p < 0.03) or a astronomically large.
    // There Lambda = a M1(p) - 1/2 + O(mu): once a M1(p) > e^40 that is a M1(p) to f64 precision,
    // taken in logarithms (overflowing to Lambda = inf, G1 = 0). Where both can be computed, the
    // quadrature and the asymptote agree to 1e-14 (p = 0.012 to 0.02, unit test).
    let ln_leading = -ln_mu + ln_gamma(1.5 / p) - ln_gamma(1.0 / p) - PI.ln();
    if (y_hi > Y_OVERFLOW || 3.0 * y_hi + 2.0 * ln_mu > LN_OVERFLOW) && ln_leading > 40.0 {
        return exact(ln_leading.exp());
    }
    let y_lo = y_of_ln_ratio(ln_rho_lo - ln_mu);
    let mut breaks = vec![y_lo];
    for ln_rho in [0.0, ln_rho_peak] {
        let y = y_of_ln_ratio(ln_rho - ln_mu);
        if y > y_lo && y < y_hi {
            breaks.push(y);
        }
    }
    breaks.push(y_hi);
    breaks.sort_by(f64::total_cmp);

    let r = quadrature::integrate(|y| lambda_integrand(y, mu, t0, two_p), &breaks, rel_tol, f64::MIN_POSITIVE);
    // 2 N(p) exp(-t0) r, combined in logarithms: exp(-t0) alone may be subnormal.
    let ln_scale = (2.0 * norm(p)).ln() - t0;
    let scaled = |x: f64| if x > 0.0 { (ln_scale + x.ln()).exp() } else { 0.0 };
    Integral { value: scaled(r.value), error: scaled(r.error), ..r }
}

/// ln of the largest f64 the integrand's product may reach (f64::MAX = e^709.8), with room to spare,
/// and the largest y whose cosh and sinh (from e^(2y)) stay finite.
const LN_OVERFLOW: f64 = 700.0;
const Y_OVERFLOW: f64 = 350.0;

/// The integrand of `lambda_integral` in y (rho = mu cosh y), with exp(-t0),
/// t0 = mu^(2p), factored out so that it stays far from underflow.
#[inline]
pub fn lambda_integrand(y: f64, mu: f64, t0: f64, two_p: f64) -> f64 {
    // sinh and cosh from one expm1 (accurate for small y).
    let em1 = y.exp_m1();
    let s = 0.5 * (em1 + em1 / (em1 + 1.0));
    let rho = mu * (1.0 + 0.5 * em1 * em1 / (em1 + 1.0));
    let q = mu * s;
    rho * q * x_minus_atan(s) * (t0 - rho.powf(two_p)).exp()
}

/// Lambda(p, a) (see `lambda_integral`).
pub fn lambda(p: f64, a: f64) -> f64 {
    lambda_integral(p, a).value
}

/// ln of an upper bound on Lambda(p, a), from sqrt(rho^2-mu^2)/mu - acos(mu/rho) <= rho/mu:
/// Lambda <= N(p) / (p mu) Gamma(2/p, mu^(2p)), and for x > s - 1 >= 0
/// Gamma(s, x) <= x^(s-1) e^-x x / (x - s + 1). None when that bound does not apply.
fn ln_lambda_upper_bound(p: f64, a: f64) -> Option<f64> {
    let s = 2.0 / p;
    let ln_mu = -a.ln();
    let x = (2.0 * p * ln_mu).exp();
    (s >= 1.0 && x > s - 1.0).then(|| norm(p).ln() - p.ln() - ln_mu + (s - 1.0) * x.ln() - x + (x / (x - s + 1.0)).ln())
}

/// Smith's G1 = 1 / (1 + Lambda(p, a)); G1(p, 0) = 1, G1(p, inf) = 0.
pub fn g1(p: f64, a: f64) -> f64 {
    g1_tol(p, a, LAMBDA_REL_TOL)
}

/// `g1` with the Lambda quadrature at relative tolerance `rel_tol`.
pub fn g1_tol(p: f64, a: f64, rel_tol: f64) -> f64 {
    g1_counted(p, a, rel_tol).0
}

/// `g1_tol` and the number of integrand evaluations it took (`twoscale bench`'s profile).
pub fn g1_counted(p: f64, a: f64, rel_tol: f64) -> (f64, usize) {
    if a.is_infinite() {
        return (0.0, 0);
    }
    // 1 + Lambda rounds to 1 in f64 when Lambda < 2^-53: skip the quadrature
    // when Lambda is proven below 1e-17.
    if ln_lambda_upper_bound(p, a).is_some_and(|b| b < (1e-17f64).ln()) {
        return (1.0, 0);
    }
    let lambda = lambda_integral_tol(p, a, rel_tol);
    (1.0 / (1.0 + lambda.value), lambda.evaluations)
}

/// CDF of D(m) cos theta_m at theta: P(1/p, (tan^2 theta / beta^2)^p), the regularised lower incomplete gamma.
pub fn epd_cdf(p: f64, beta: f64, theta: f64) -> f64 {
    if theta >= FRAC_PI_2 {
        return 1.0;
    }
    let (a, x) = (1.0 / p, (theta.tan() / beta).powi(2).powf(p));
    if x < 1e-8 {
        // statrs returns 0 below x ~ 1e-15 (and fails at 0): the series'
        // first two terms, x^a / Gamma(a + 1) (1 - a x / (a + 1)), exact to O(x^2).
        return if x > 0.0 { (a * x.ln() - ln_gamma(a + 1.0)).exp() * (1.0 - a * x / (a + 1.0)) } else { 0.0 };
    }
    statrs::function::gamma::gamma_lr(a, x)
}

/// The same CDF by quadrature, independent of the incomplete gamma:
/// p / Gamma(1/p) int_0^z exp(-y^p) dy with z = tan^2 theta / beta^2.
pub fn epd_cdf_by_quadrature(p: f64, beta: f64, theta: f64) -> f64 {
    if theta >= FRAC_PI_2 {
        return 1.0;
    }
    let z = (theta.tan() / beta).powi(2);
    let f = |y: f64| (-y.powf(p)).exp();
    // Pieces growing geometrically from 1e-3: the quadrature rule stops at ~385 evaluations per call.
    let (mut a, mut step, mut sum) = (0.0, 1e-3f64.min(z), 0.0);
    while a < z {
        let b = (a + step).min(z);
        sum += ::quadrature::double_exponential::integrate(f, a, b, 1e-14).integral;
        a = b;
        step *= 2.0;
    }
    p / crate::numerics::special::gamma(1.0 / p) * sum
}

/// theta with epd_cdf(theta) = xi, by bisection in theta (to f64 resolution).
pub fn epd_quantile(p: f64, beta: f64, xi: f64) -> f64 {
    if xi <= 0.0 {
        return 0.0;
    }
    if xi >= 1.0 {
        return FRAC_PI_2;
    }
    let (mut lo, mut hi) = (0.0, FRAC_PI_2);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if epd_cdf(p, beta, mid) < xi {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the quadrature overflows (small p, huge a) Lambda is its asymptote a M1(p) - 1/2;
    /// where both can be computed they agree, and G1 keeps falling with a up to f64's range.
    #[test]
    fn lambda_asymptote_where_the_quadrature_overflows() {
        for (p, ln_a) in [(0.015, 100.0), (0.015, 150.0), (0.02, 100.0), (0.02, 200.0)] {
            let a = f64::exp(ln_a);
            let quad = lambda_integral_tol(p, a, 1e-10);
            assert!(quad.converged && quad.evaluations > 0, "p={p} a=e^{ln_a}: the quadrature ran");
            let asymptote = a * m1(p) - 0.5;
            assert!((quad.value / asymptote - 1.0).abs() < 1e-12, "p={p} a=e^{ln_a}: {} vs {asymptote}", quad.value);
        }
        let far = lambda_integral_tol(0.015, f64::exp(170.0), 1e-10);
        assert_eq!(far.evaluations, 0, "p=0.015, a=e^170: the asymptote, not the quadrature");
        for p in [0.01, 0.02, 0.05] {
            let mut last = 1.0;
            for k in -30..=308 {
                let g = g1(p, 10f64.powi(k));
                assert!((0.0..=last * (1.0 + 1e-12)).contains(&g), "p={p} a=1e{k}: G1 {g} after {last}");
                last = g;
            }
            assert_eq!(g1(p, 1e300), 0.0, "p={p}: G1 underflows to 0 at a = 1e300 (Lambda > 1e308)");
        }
    }
}
