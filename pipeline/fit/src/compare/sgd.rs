//! Bagher, Soler and Holzschuch 2012's Shifted Gamma Distribution ("Accurate fitting of measured
//! reflectances using a Shifted Gamma micro-facet distribution"), in the form its published fits have
//! (`published::Sgd`, checked against their golden values): per channel
//! rho = (rhoD + rhoS F(cd) D(ch) G1(wi) G1(wo) / (ci co)) / pi, D = kap exp(-x) / (pi x^p ch^4),
//! x = alpha + tan^2 theta_h / alpha, F = f0 - cd f1 + (1 - cd)^5 (1 - f0).
//!
//! Fitted: rhoD, rhoS, alpha, p, f0 and f1 per channel, the paper's 18 parameters. Held: kap, which
//! normalises D and is a factor of rhoS, at 1; the published fits' empirical shadowing
//! G1 = clamp(1 + lambda (1 - exp(c max(0, theta - theta0)^k)), 0, 1) at 1 (lambda = 0; its four
//! parameters per channel reach 1e-8 to 1e38 in the published fits, a fit of its own beyond what the
//! paper counts). The values keep all 11 per channel, so that a published fit is one of them.

use super::parameter::{per_channel, Parameter};
use crate::params::Range;
use crate::published::Sgd;

/// The parameters per channel, in sgd.json's order, and whether each is fitted.
const fn parameters() -> [Parameter; 33] {
    let [d0, d1, d2] = per_channel("rhoD", Some(Range::Linear(0.0, 1.0)));
    let [s0, s1, s2] = per_channel("rhoS", Some(Range::Log(1e-6, 1e6)));
    let [a0, a1, a2] = per_channel("alpha", Some(Range::Log(1e-5, 2.0)));
    let [p0, p1, p2] = per_channel("p", Some(Range::Linear(0.0, 3.0)));
    let [f00, f01, f02] = per_channel("f0", Some(Range::Log(1e-4, 10.0)));
    let [f10, f11, f12] = per_channel("f1", Some(Range::Linear(-1.0, 10.0)));
    let [k0, k1, k2] = per_channel("kap", None);
    let [l0, l1, l2] = per_channel("lambda", None);
    let [c0, c1, c2] = per_channel("c", None);
    let [e0, e1, e2] = per_channel("k", None);
    let [t0, t1, t2] = per_channel("theta0", None);
    [
        d0, d1, d2, s0, s1, s2, a0, a1, a2, p0, p1, p2, f00, f01, f02, f10, f11, f12, k0, k1, k2, l0, l1, l2, c0, c1,
        c2, e0, e1, e2, t0, t1, t2,
    ]
}

pub(crate) const PARAMETERS: [Parameter; 33] = parameters();

pub(crate) fn sgd(v: &[f64]) -> Sgd {
    let channel = |k: usize| [v[3 * k], v[3 * k + 1], v[3 * k + 2]];
    Sgd {
        rho_d: channel(0),
        rho_s: channel(1),
        alpha: channel(2),
        p: channel(3),
        f0: channel(4),
        f1: channel(5),
        kap: channel(6),
        lambda: channel(7),
        c: channel(8),
        k: channel(9),
        theta0: channel(10),
        error: [0.0; 3],
    }
}

/// A grid of lobes (alpha, p), rhoS at two scales of the lobe's integral (which goes as alpha^(1 - p)
/// where alpha is small), a dark or a bright base, F a dielectric's (f0 0.1, f1 0).
pub(crate) fn starts() -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    for alpha in [0.003f64, 0.03, 0.3] {
        for p in [0.3f64, 1.0] {
            for scale in [0.05, 0.5] {
                for rho_d in [0.02, 0.2] {
                    let rho_s = scale * alpha.powf(p - 1.0);
                    // kap 1 and G1 1: lambda 0 (c 0, k 1, theta0 0)
                    let held = [[1.0; 3], [0.0; 3], [0.0; 3], [1.0; 3], [0.0; 3]];
                    out.push(
                        [[rho_d; 3], [rho_s; 3], [alpha; 3], [p; 3], [0.1; 3], [0.0; 3]]
                            .iter()
                            .chain(&held)
                            .flatten()
                            .copied()
                            .collect(),
                    );
                }
            }
        }
    }
    out
}
