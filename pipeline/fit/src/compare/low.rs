//! Löw, Andersson, Ynnerman and Unger 2012 ("BRDF models for accurate and efficient rendering of glossy
//! surfaces"): their smooth-surface model and their microfacet model with the ABC distribution, each
//! over a Lambertian base (the 9 parameters their fits have).
//!
//! - `low_smooth`, as bsdfbenchmark/bbm's `lowsmooth.h` evaluates it (pipeline/fit/golden checks it):
//!   rho = kd / pi + A S Q per channel, S = (1 + B |Ip + Op|^2)^-C with Ip, Op the directions' projections
//!   on the surface (|Ip + Op| is the distance of wo's projection from the mirror direction's), and Q the
//!   unpolarised dielectric Fresnel factor of index eta at cos theta_d = sqrt(1 - |Ip - Op|^2 / 4);
//! - `abc`: rho = kd / pi + F D G / (pi ci co), D = A / (1 + B (1 - ch))^C, in the form the published
//!   fits have (`published::Abc`, checked against their golden values).

use super::parameter::{per_channel, shared, Parameter};
use crate::params::Range;
use crate::published::{dielectric_fresnel, Abc};
use std::f64::consts::PI;

/// Per channel kd and A, then B, C and the index.
const fn parameters(b: Range) -> [Parameter; 9] {
    let [kd0, kd1, kd2] = per_channel("kd", Some(Range::Linear(0.0, 1.0)));
    let [a0, a1, a2] = per_channel("A", Some(Range::Log(1e-3, 1e7)));
    [
        kd0,
        kd1,
        kd2,
        a0,
        a1,
        a2,
        shared("B", b),
        shared("C", Range::Log(1e-3, 10.0)),
        shared("eta", Range::Log(1.001, 100.0)),
    ]
}

/// B's ranges: 1 - ch reaches 1 at grazing, |Ip + Op|^2 four; both down to a mirror's lobe.
pub(crate) const SMOOTH: [Parameter; 9] = parameters(Range::Log(0.1, 1e9));
pub(crate) const ABC: [Parameter; 9] = parameters(Range::Log(1.0, 1e9));

/// The smooth-surface model's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowSmooth {
    pub kd: [f64; 3],
    pub a: [f64; 3],
    pub b: f64,
    pub c: f64,
    pub eta: f64,
}

impl LowSmooth {
    /// The BRDF (1/sr) for the directions to the light `wi` and to the viewer `wo` (unit vectors, z the
    /// normal); 0 below the horizon.
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        if wi[2] < 0.0 || wo[2] < 0.0 {
            return [0.0; 3];
        }
        let dp2 = (wi[0] + wo[0]).powi(2) + (wi[1] + wo[1]).powi(2);
        let cos_d = (1.0 - 0.25 * ((wi[0] - wo[0]).powi(2) + (wi[1] - wo[1]).powi(2))).max(0.0).sqrt();
        let sq = (1.0 + self.b * dp2).powf(-self.c) * dielectric_fresnel(cos_d, self.eta);
        [0, 1, 2].map(|ch| self.kd[ch] / PI + self.a[ch] * sq)
    }
}

pub(crate) fn smooth(v: &[f64]) -> LowSmooth {
    LowSmooth { kd: [v[0], v[1], v[2]], a: [v[3], v[4], v[5]], b: v[6], c: v[7], eta: v[8] }
}

pub(crate) fn abc(v: &[f64]) -> Abc {
    Abc { kd: [v[0], v[1], v[2]], a: [v[3], v[4], v[5]], b: v[6], c: v[7], ior: v[8] }
}

/// A grid of lobes (B, C), each with its peak A at three scales relative to the lobe's width (the
/// lobe's integral goes as A / B), a dark or a bright base, and a glass-like index.
fn starts(bs: [f64; 3]) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    for b in bs {
        for c in [0.7, 1.5] {
            for scale in [0.003, 0.03, 0.3] {
                for kd in [0.02, 0.2] {
                    let a = scale * b;
                    out.push(vec![kd, kd, kd, a, a, a, b, c, 1.5]);
                }
            }
        }
    }
    out
}

pub(crate) fn smooth_starts() -> Vec<Vec<f64>> {
    starts([10.0, 1e3, 1e5])
}

pub(crate) fn abc_starts() -> Vec<Vec<f64>> {
    starts([1e2, 1e4, 1e6])
}
