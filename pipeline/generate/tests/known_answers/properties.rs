//! Property tests over the stress domain of `twoscale stress` (issue 7): the
//! invariants docs/maths.md states, at random points up to and beyond the domain edges.

use proptest::prelude::*;
use twoscale_generate::tables::epd_math::g1;
use twoscale_generate::tables::kcorr_math::renorm;
use twoscale_generate::tables::zh_math::{d_lobe, s_lobe};

/// s in [0, 1] with as much weight near 1 (down to 1e-15 from it) as elsewhere.
fn s_strategy() -> impl Strategy<Value = f64> {
    prop_oneof![0.0f64..1.0, (0.0f64..15.0).prop_map(|k| 1.0 - 10f64.powf(-k)), Just(0.0), Just(1.0)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn g1_in_unit_interval_and_non_increasing(lp in -2.0f64..2.0, la in -30.0f64..30.0, dla in 1e-3f64..5.0) {
        let p = 10f64.powf(lp);
        let (a1, a2) = (10f64.powf(la), 10f64.powf(la + dla));
        let (g_1, g_2) = (g1(p, a1), g1(p, a2));
        prop_assert!((0.0..=1.0).contains(&g_1) && (0.0..=1.0).contains(&g_2), "p={} a={}: {}", p, a1, g_1);
        prop_assert!(g_2 <= g_1 * (1.0 + 1e-12), "p={} a={}: {} then a={}: {}", p, a1, g_1, a2, g_2);
    }

    #[test]
    fn renorm_in_unit_interval_monotone_in_s_and_b(
        s in s_strategy(), ds in 1e-15f64..0.5, lb in -6.0f64..8.0, dlb in 1e-3f64..1.0, lc in -9.0f64..4.0,
    ) {
        let (b, c) = (10f64.powf(lb), 1.0 + 10f64.powf(lc));
        let s2 = (s + ds).min(1.0);
        let (r, r_s, r_b) = (renorm(s, b, c), renorm(s2, b, c), renorm(s, b * 10f64.powf(dlb), c));
        prop_assert!((0.0..=1.0).contains(&r), "s={} B={} c={}: {}", s, b, c, r);
        prop_assert!(r_s <= r * (1.0 + 1e-12) + 1e-300, "s {} -> {}: {} -> {}", s, s2, r, r_s);
        prop_assert!(r_b >= r * (1.0 - 1e-12), "B {} up: {} -> {}", b, r, r_b);
    }

    #[test]
    fn diffraction_lobe_in_unit_interval_non_increasing(lu in -6.0f64..4.0, zero in any::<bool>(), lc in -9.0f64..4.0, t1 in 0.0f64..std::f64::consts::FRAC_PI_2, dt in 0.0f64..1.0) {
        let (u, c) = (if zero { 0.0 } else { 10f64.powf(lu) }, 1.0 + 10f64.powf(lc));
        let t2 = (t1 + dt).min(std::f64::consts::FRAC_PI_2);
        let at = |t: f64| s_lobe(t.sin().powi(2), t.cos().powi(2), u, c);
        let (v1, v2) = (at(t1), at(t2));
        prop_assert!((0.0..=1.0).contains(&v1), "u={} c={} theta={}: {}", u, c, t1, v1);
        prop_assert!(v2 <= v1 * (1.0 + 1e-12), "u={} c={}: {} at {} then {} at {}", u, c, v1, t1, v2, t2);
    }

    #[test]
    fn ndf_lobe_finite_and_non_negative(lbeta in -5.0f64..std::f64::consts::LOG10_2, lp in -2.0f64..2.0, t in 0.0f64..=std::f64::consts::FRAC_PI_2) {
        let v = d_lobe(t.sin().powi(2), t.cos().powi(2), 10f64.powf(lp), 10f64.powf(lbeta));
        prop_assert!(v.is_finite() && v >= 0.0, "{}", v);
    }
}
