//! The SIMD-friendly ln, exp and cos of `twoscale_tables::vector_math` (shared with the reader's
//! batched BRDF), re-exported for the builders, and their accuracy against libm.

pub use twoscale_tables::vector_math::*;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::sampling::SplitMix64;

    /// Distance in units in the last place between two finite doubles of the same sign.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    #[test]
    fn ln_within_one_ulp_of_libm() {
        let mut rng = SplitMix64::new(1);
        let mut worst = 0;
        for i in 0..200_000 {
            // Log-uniform over the normal range, plus values just around 1.
            let x = if i % 2 == 0 {
                2f64.powf(-1021.0 + 2044.0 * rng.uniform())
            } else {
                1.0 + (rng.uniform() - 0.5) * 1e-3
            };
            worst = worst.max(ulps(ln(x), x.ln()));
        }
        assert!(worst <= 1, "{worst} ulp");
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
        assert!(ln(f64::NAN).is_nan());
    }

    #[test]
    fn exp_within_one_ulp_of_libm() {
        let mut rng = SplitMix64::new(2);
        let mut worst = 0;
        for i in 0..200_000 {
            let x = if i % 2 == 0 { -708.0 + 1417.0 * rng.uniform() } else { (rng.uniform() - 0.5) * 1e-6 };
            worst = worst.max(ulps(exp(x), x.exp()));
        }
        assert!(worst <= 1, "{worst} ulp");
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-1000.0), 0.0);
        assert!(exp(f64::NAN).is_nan());
    }

    #[test]
    fn cos_0_pi_within_4e_16_of_libm() {
        let mut rng = SplitMix64::new(3);
        let worst = (0..200_000)
            .map(|_| std::f64::consts::PI * rng.uniform())
            .chain([0.0, std::f64::consts::PI])
            .fold(0.0f64, |m, x| m.max((cos_0_pi(x) - x.cos()).abs()));
        assert!(worst <= 4e-16, "{worst:e}");
    }
}
