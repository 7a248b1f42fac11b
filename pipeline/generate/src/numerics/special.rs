//! Special functions (thin wrappers over the `special` crate, which calls libm).

use special::{Error, Gamma};

/// Gamma(x).
pub fn gamma(x: f64) -> f64 {
    Gamma::gamma(x)
}

/// ln |Gamma(x)|.
pub fn ln_gamma(x: f64) -> f64 {
    Gamma::ln_gamma(x).0
}

/// Complementary error function erfc(x) = 1 - erf(x), accurate in the tail.
pub fn erfc(x: f64) -> f64 {
    Error::compl_error(x)
}

/// acosh(z) for z >= 1 without overflow for huge z.
pub fn acosh(z: f64) -> f64 {
    if z > 1e8 {
        (2.0 * z).ln() // error ~ 1/(4 z^2)
    } else {
        z.acosh()
    }
}

/// x - atan(x) for x >= 0, accurate to a few ulp also for small x where
/// the difference cancels (series x^3/3 - x^5/5 + ...).
pub fn x_minus_atan(x: f64) -> f64 {
    if x < 0.1 {
        // x^3 (1/3 - x^2 (1/5 - x^2 (1/7 - ...))): the next term is < 1e-15 relative.
        let x2 = x * x;
        let mut t = 0.0;
        for k in (1..=7).rev() {
            t = 1.0 / (2 * k + 1) as f64 - x2 * t;
        }
        x * x2 * t
    } else {
        x - x.atan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_known_values() {
        assert!((gamma(5.0) - 24.0).abs() < 1e-13);
        assert!((gamma(0.5) - std::f64::consts::PI.sqrt()).abs() < 1e-15);
        assert!((ln_gamma(20.0) - 121_645_100_408_832_000f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn erfc_tail() {
        // erfc(5) = 1.5374597944280348502e-12 (A&M table value).
        assert!((erfc(5.0) / 1.537_459_794_428_034_8e-12 - 1.0).abs() < 1e-13);
    }

    #[test]
    fn x_minus_atan_matches_series_and_direct() {
        for &x in &[1e-8, 1e-3, 0.05, 0.0999, 0.1, 0.5, 3.0, 1e6] {
            let direct = x - f64::atan(x);
            let v = x_minus_atan(x);
            if x >= 0.01 {
                assert!((v / direct - 1.0).abs() < 1e-11, "x={x}: {v} vs {direct}");
            }
            // Leading term of the series.
            if x < 1e-2 {
                assert!((v / (x * x * x / 3.0) - 1.0).abs() < x * x, "x={x}: {v}");
            }
        }
        // Continuity across the switch at 0.1.
        let below = x_minus_atan(0.1 - 1e-15);
        let above = x_minus_atan(0.1);
        assert!((below / above - 1.0).abs() < 1e-12);
    }

    #[test]
    fn acosh_is_continuous_at_switch() {
        let z = 1e8;
        assert!((acosh(z * (1.0 - 1e-15)) - acosh(z)).abs() < 1e-12);
    }
}
