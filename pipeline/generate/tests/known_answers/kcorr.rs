//! R(s, B, c) of docs/maths.md section 3 against known answers: an independent 2-D
//! quadrature over the disk, limits, monotonicity and stability at the edges.

use crate::de_split;
use proptest::prelude::*;
use std::f64::consts::PI;
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::tables::kcorr_math::{renorm, renorm_row, renorm_tol};

/// R as a 2-D integral in polar coordinates around the origin: each ray at
/// angle phi leaves the disk |g - (s, 0)| <= 1 at rho_max = s cos(phi) + sqrt(1 - s^2 sin^2(phi)).
fn renorm_2d(s: f64, b: f64, c: f64) -> f64 {
    let psd = |rho: f64| b * b * (c - 1.0) / (2.0 * PI) * (1.0 + b * b * rho * rho).powf(-(c + 1.0) / 2.0);
    let radial = |phi: f64| {
        let rho_max = (s * phi.cos() + (1.0 - s * s * phi.sin().powi(2)).max(0.0).sqrt()).max(0.0);
        de_split(&|rho: f64| psd(rho) * rho, 0.0, rho_max, 1.0 / b, 4.0)
    };
    // Symmetric in phi; the kink of rho_max at phi = pi/2 when s = 1.
    2.0 * (de_split(&radial, 0.0, PI / 2.0, PI / 2.0, 4.0) + de_split(&radial, PI / 2.0, PI, PI / 2.0, 4.0))
}

#[test]
fn independent_two_dimensional_quadrature() {
    for &s in &[0.1, 0.5, 0.9, 0.99, 1.0] {
        for &(b, c) in &[(0.1, 1.5), (2.0, 1.01), (2.0, 3.0), (30.0, 2.0), (300.0, 11.0)] {
            let reference = renorm_2d(s, b, c);
            let got = renorm(s, b, c);
            assert!((got / reference - 1.0).abs() < 1e-9, "s={s} B={b} c={c}: {got} vs 2-D {reference}");
        }
    }
}

#[test]
fn default_tolerance_is_converged() {
    // Catches an error estimate that is optimistic (a feature between the
    // Gauss-Kronrod nodes): the default result must agree with a 1e-14 run.
    let mut rng = SplitMix64::new(5);
    for k in 0..3000 {
        let u = rng.uniform();
        let s = if k % 2 == 0 { u } else { 1.0 - 10f64.powf(-1.0 - 14.0 * u) };
        let b = 10f64.powf(-1.0 + 4.0 * rng.uniform());
        let c = 1.0 + 10f64.powf(-2.0 + 4.0 * rng.uniform());
        let (r, reference) = (renorm(s, b, c), renorm_tol(s, b, c, 1e-14));
        assert!((r / reference - 1.0).abs() < 1e-10, "s={s} B={b} c={c}: {r} vs {reference}");
    }
}

#[test]
fn the_tables_row_rule_agrees_with_the_adaptive_one() {
    // renorm_row (what kcorr_renorm stores) shares one Gauss-Legendre rule across a row of (B, c): against
    // a 1e-14-tolerance evaluation over the tables' domain (B to 1000, c to 101), s near 1 as often as not.
    let mut rng = SplitMix64::new(11);
    let mut worst = 0f64;
    for k in 0..2000 {
        let u = rng.uniform();
        let s = if k % 2 == 0 { u } else { 1.0 - 10f64.powf(-1.0 - 14.0 * u) };
        let b = 10f64.powf(-1.0 + 4.0 * rng.uniform());
        let c = 1.01 + 100.0 * rng.uniform().powi(3);
        let (r, reference) = (renorm_row(s, &[b], &[c])[0], renorm_tol(s, b, c, 1e-14));
        worst = worst.max((r / reference - 1.0).abs());
        assert!((r / reference - 1.0).abs() < 1e-11, "s={s} B={b} c={c}: {r} vs {reference}");
    }
    // a row is its points one by one, in C order over (B, c)
    let (bs, cs) = ([0.1, 3.0, 1000.0], [1.01, 2.2, 101.0]);
    let row = renorm_row(0.7, &bs, &cs);
    for (j, &b) in bs.iter().enumerate() {
        for (k, &c) in cs.iter().enumerate() {
            assert_eq!(row[j * cs.len() + k], renorm_row(0.7, &[b], &[c])[0], "B={b} c={c}");
        }
    }
    println!("renorm_row against R at 1e-14: {worst:.1e} relative at most over 2000 points");
}

#[test]
fn large_b_limits() {
    // 1 - R vanishes like B^(1-c) (the PSD mass beyond radius ~1); at s = 1 the
    // disk's curvature adds ~1/(4B) to |R - 1/2|.
    for &c in &[1.5, 3.0, 50.0] {
        for &b in &[1e4f64, 1e6] {
            let bound = 2.0 * b.powf(1.0 - c) + 1e-12;
            let r = renorm(0.3, b, c);
            assert!(1.0 - r <= bound, "c={c} B={b}: R(0.3) = {r}");
            let r1 = renorm(1.0, b, c);
            assert!((r1 - 0.5).abs() <= bound + 2.0 / b, "c={c} B={b}: R(1) = {r1}");
        }
        assert!((renorm(1.0, 1e6, c) - 0.5).abs() <= (renorm(1.0, 1e4, c) - 0.5).abs() + 1e-12);
    }
}

#[test]
fn edges_are_finite_in_range_and_continuous() {
    for &s in &[0.0, 1e-12, 1.0 - 1e-12, 1.0] {
        for &c in &[1.0 + 1e-6, 1000.0] {
            for &b in &[1e-3, 1e6] {
                let r = renorm(s, b, c);
                assert!(r.is_finite() && (0.0..=1.0).contains(&r), "s={s} B={b} c={c}: {r}");
                // A neighbour 1e-15 away in s (R varies on a scale >= 1/B = 1e-6).
                let s2 = if s < 0.5 { s + 1e-15 } else { s - 1e-15 };
                let r2 = renorm(s2, b, c);
                assert!((r - r2).abs() <= 1e-6 * r + 1e-300, "s={s} B={b} c={c}: {r} vs {r2}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn in_unit_interval_decreasing_in_s_increasing_in_b(
        s in 0.0f64..1.0, ds in 1e-6f64..0.5, lb in -1.0f64..3.0, dlb in 1e-4f64..1.0, c in 1.01f64..101.0,
    ) {
        let b = 10f64.powf(lb);
        let s2 = (s + ds).min(1.0);
        let (r, r_s, r_b) = (renorm(s, b, c), renorm(s2, b, c), renorm(s, b * 10f64.powf(dlb), c));
        prop_assert!((0.0..=1.0).contains(&r));
        prop_assert!(r_s <= r * (1.0 + 1e-12), "s {} -> {}: {} -> {}", s, s2, r, r_s);
        prop_assert!(r_b >= r * (1.0 - 1e-12), "B up: {} -> {}", r, r_b);
    }
}
