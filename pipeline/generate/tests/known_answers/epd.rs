//! Lambda, G1 and N(p) of the EPD against known answers (docs/maths.md sections 1-2):
//! closed forms, limits and an independent two-dimensional quadrature.

use crate::de_split;
use proptest::prelude::*;
use std::f64::consts::PI;
use twoscale_generate::numerics::special::erfc;
use twoscale_generate::tables::epd::norm_by_quadrature;
use twoscale_generate::tables::epd_math::{g1, lambda, m1, norm};

/// Beckmann (p = 1): Lambda = (exp(-mu^2)/(mu sqrt(pi)) - erfc(mu)) / 2. For
/// mu > 8 the two terms cancel by more than 2 digits, so use the asymptotic
/// series of erfc instead (its smallest term, ~exp(-mu^2), bounds its error):
/// Lambda = exp(-mu^2)/(2 mu sqrt(pi)) sum_k>=1 (-1)^(k+1) (2k-1)!! / (2 mu^2)^k.
fn beckmann_lambda(a: f64) -> f64 {
    let mu = 1.0 / a;
    if mu <= 8.0 {
        return 0.5 * ((-mu * mu).exp() / (mu * PI.sqrt()) - erfc(mu));
    }
    let x = 1.0 / (2.0 * mu * mu);
    let (mut term, mut sum) = (x, 0.0);
    for k in 1..80 {
        sum += term;
        term *= -(2.0 * k as f64 + 1.0) * x;
        if term.abs() < 1e-18 * sum.abs() {
            break;
        }
    }
    (-mu * mu).exp() / (2.0 * mu * PI.sqrt()) * sum
}

#[test]
fn beckmann_closed_form() {
    let mut worst_g1 = 0.0f64;
    let mut worst_lambda = 0.0f64;
    for i in 0..=600 {
        let a = 10f64.powf(-3.0 + 6.0 * i as f64 / 600.0);
        let exact = beckmann_lambda(a);
        let l = lambda(1.0, a);
        worst_g1 = worst_g1.max((g1(1.0, a) * (1.0 + exact) - 1.0).abs());
        if exact > 1e-300 {
            worst_lambda = worst_lambda.max((l / exact - 1.0).abs());
        } else {
            assert!(l < 1e-290, "a={a}: lambda {l} where the closed form underflows");
        }
    }
    assert!(worst_g1 < 1e-9, "G1 relative error {worst_g1:e}");
    assert!(worst_lambda < 1e-10, "Lambda relative error {worst_lambda:e}");
}

#[test]
fn large_a_asymptote() {
    // Lambda(p, a) + 1/2 - a M1(p) -> 0 as a -> inf.
    for &p in &[0.05, 0.1, 0.3, 1.0, 2.5, 5.0] {
        let gap = |a: f64| (lambda(p, a) + 0.5 - a * m1(p)).abs();
        for &a in &[1e6, 1e9] {
            let rel = gap(a) / (a * m1(p));
            assert!(rel < 1e-10, "p={p} a={a}: relative gap {rel:e}");
        }
        // The gap itself shrinks like 1/a (M1 is an independent closed form); at
        // Lambda ~ 1e2 and 1e4 it is well above the rounding of Lambda.
        let (g2, g4) = (gap(1e2 / m1(p)), gap(1e4 / m1(p)));
        assert!(g4 < 0.1 * g2 + 1e-11, "p={p}: gap {g2:e} then {g4:e}");
    }
}

/// p -> inf: the slope density becomes the uniform unit disk, for which
/// Lambda(mu) = (1/pi) [ (2/3)(1-mu^2)^(3/2)/mu - acos(mu) + mu sqrt(1-mu^2) ], mu < 1.
fn disk_lambda(mu: f64) -> f64 {
    if mu >= 1.0 {
        return 0.0;
    }
    let r = 1.0 - mu * mu;
    ((2.0 / 3.0) * r.powf(1.5) / mu - mu.acos() + mu * r.sqrt()) / PI
}

#[test]
fn large_p_disk_limit() {
    for &a in &[1.2, 2.0, 5.0, 30.0] {
        let mu = 1.0 / a;
        let exact = disk_lambda(mu);
        let e2 = (lambda(1e2, a) - exact).abs();
        let e3 = (lambda(1e3, a) - exact).abs();
        let e4 = (lambda(1e4, a) - exact).abs();
        // Converges like 1/p.
        assert!(e3 < 0.2 * e2 && e4 < 0.2 * e3, "a={a}: {e2:e} {e3:e} {e4:e}");
        assert!(e4 < 1e-3 * exact.max(1.0), "a={a}: p=1e4 differs by {e4:e} from {exact}");
    }
    // Inside mu > 1 the disk gives 0; p = 1e4 is then vanishingly small.
    assert!(lambda(1e4, 0.9) < 1e-12);
}

/// The first form of docs/maths.md section 2, by nested double-exponential quadrature
/// (the `quadrature` crate): Lambda = (1/mu) int_mu^inf (x - mu) P2(x) dx,
/// P2(x) = 2 N(p) int_0^inf exp(-(x^2 + y^2)^p) dy.
fn lambda_2d(p: f64, a: f64) -> f64 {
    let mu = 1.0 / a;
    let reach = 60f64.powf(0.5 / p); // exp(-rho^(2p)) < e^-60 beyond
    let p2 = |x: f64| 2.0 * norm(p) * de_split(&|y: f64| (-(x * x + y * y).powf(p)).exp(), 0.0, reach, 0.25, 2.0);
    de_split(&|x: f64| (x - mu) * p2(x), mu, reach, 0.25, 2.0) / mu
}

#[test]
fn independent_two_dimensional_quadrature() {
    for &p in &[0.5, 0.8, 1.5, 3.0] {
        for &a in &[0.7, 1.0, 4.0] {
            let reference = lambda_2d(p, a);
            let got = lambda(p, a);
            assert!((got / reference - 1.0).abs() < 1e-8, "p={p} a={a}: {got} vs 2-D {reference}");
        }
    }
}

#[test]
fn g1_ends() {
    for &p in &[0.05, 0.2, 1.0, 3.7, 5.0] {
        assert_eq!(g1(p, 0.0), 1.0);
        assert_eq!(g1(p, f64::INFINITY), 0.0);
    }
}

#[test]
fn norm_closed_form_and_definition() {
    assert!((norm(1.0) - 1.0 / PI).abs() < 1e-16);
    assert!((norm(0.5) - 0.5 / PI).abs() < 1e-16);
    assert_eq!(norm(0.0), 0.0);
    for &p in &[0.05, 0.13, 0.7, 1.0, 2.2, 5.0] {
        let q = norm_by_quadrature(p);
        assert!((norm(p) / q - 1.0).abs() < 1e-11, "p={p}: {} vs {q}", norm(p));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn g1_is_a_decreasing_probability(p in 0.05f64..5.0, la in -20.0f64..10.0, dla in 0.001f64..3.0) {
        let (a1, a2) = (10f64.powf(la), 10f64.powf(la + dla));
        let (g_1, g_2) = (g1(p, a1), g1(p, a2));
        prop_assert!((0.0..=1.0).contains(&g_1) && (0.0..=1.0).contains(&g_2));
        prop_assert!(g_2 <= g_1, "p={} a={}: {} then a={}: {}", p, a1, g_1, a2, g_2);
    }
}
