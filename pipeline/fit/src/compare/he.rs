//! He, Torrance, Sillion and Greenberg 1991 ("A comprehensive physical model for light reflection"): the
//! directional-specular term as bsdfbenchmark/bbm's `heholzschuch` variant evaluates it (`he.h`: the
//! errata's Eq. 25 of Holzschuch and Pacanowski, He et al.'s Eq. 78, 4 Newton steps for the apparent
//! roughness, 10 terms of the series; pipeline/fit/golden checks it), over a Lambertian base. sigma (the
//! surface's RMS height) and tau (its autocorrelation length) are in micrometres, as the wavelengths;
//! the index n + ik and kd are per channel: 11 parameters. Per channel,
//!
//!   rho = F(n, k; cos theta_d) S(wi) S(wo) G D / (pi ci co) + kd / pi,
//!
//! cos theta_d = sqrt((1 + wi.wo) / 2), F the exact conductor Fresnel factor, S Smith's shadowing of a
//! Gaussian surface (Eqs. 24-25), G the geometrical factor (Eq. 76, `geometrical`), and
//! D = pi^2 tau^2 / (4 lambda^2) sum_{m=1..10} g^m / (m! m) exp(-g - v_xy^2 tau^2 / (4 m)),
//! g = (2 pi sigma0 (ci + co) / lambda)^2, sigma0 the apparent roughness (Eqs. 80-83) and v_xy the
//! projection of wi + wo on the surface.

use super::parameter::{per_channel, shared, Parameter};
use crate::params::{Range, ETA, K};
use special::Error;
use std::f64::consts::PI;
use twoscale_tables::fresnel;

/// Where BBM takes a value as 0 (its `Epsilon`, double's machine epsilon).
const EPSILON: f64 = f64::EPSILON;

/// The series' terms (the `heholzschuch` variant's fixed count).
const TERMS: usize = 10;

const fn parameters() -> [Parameter; 11] {
    let [e0, e1, e2] = per_channel("eta", Some(Range::Log(ETA.0, ETA.1)));
    let [k0, k1, k2] = per_channel("k", Some(Range::Log(K.0, K.1)));
    let [d0, d1, d2] = per_channel("kd", Some(Range::Linear(0.0, 1.0)));
    [
        shared("sigma", Range::Log(1e-4, 10.0)),
        shared("tau", Range::Log(1e-3, 100.0)),
        e0,
        e1,
        e2,
        k0,
        k1,
        k2,
        d0,
        d1,
        d2,
    ]
}

pub(crate) const PARAMETERS: [Parameter; 11] = parameters();

/// He et al.'s parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct He {
    /// RMS height and autocorrelation length (micrometres).
    pub sigma: f64,
    pub tau: f64,
    pub eta: [f64; 3],
    pub k: [f64; 3],
    pub kd: [f64; 3],
}

pub(crate) fn he(v: &[f64]) -> He {
    He { sigma: v[0], tau: v[1], eta: [v[2], v[3], v[4]], k: [v[5], v[6], v[7]], kd: [v[8], v[9], v[10]] }
}

/// tan theta of a unit vector, as BBM computes it.
fn tan_theta(w: [f64; 3]) -> f64 {
    (1.0 - w[2] * w[2]).max(0.0).sqrt() / w[2]
}

impl He {
    /// The BRDF (1/sr) for the directions to the light `wi` and to the viewer `wo` (unit vectors, z the
    /// normal), channel ch at wavelength `lambdas[ch]` (micrometres).
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3], lambdas: [f64; 3]) -> [f64; 3] {
        if wi[2] < 0.0 || wo[2] < 0.0 {
            return [0.0; 3];
        }
        let diffuse = self.kd.map(|kd| kd / PI);
        if wi[2] == 0.0 || wo[2] == 0.0 {
            return diffuse;
        }
        let (ci, co) = (wi[2], wo[2]);
        let shared = self.shadowing(wi) * self.shadowing(wo) * geometrical(wi, wo) / (PI * ci * co);
        let dot = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2];
        let cos_d = ((1.0 + dot) / 2.0).max(0.0).sqrt();
        let sigma0 = self.apparent_roughness(wi, wo);
        let tau2 = self.tau * self.tau;
        // v_xy^2 tau^2 / 4, and the series' terms
        let spread = ((wi[0] + wo[0]).powi(2) + (wi[1] + wo[1]).powi(2)) * tau2 / 4.0;
        [0, 1, 2].map(|ch| {
            let lambda = lambdas[ch];
            let g = (2.0 * PI * sigma0 * (ci + co) / lambda).powi(2);
            let (mut sum, mut gm) = (0.0, 1.0);
            for m in 1..=TERMS {
                let m = m as f64;
                gm *= g / m;
                sum += (-g - spread / m).exp() * gm / m;
            }
            let d = 0.25 * PI * PI * tau2 / (lambda * lambda) * sum;
            fresnel::conductor(cos_d, self.eta[ch], self.k[ch]) * shared * d + diffuse[ch]
        })
    }

    /// Smith's shadowing of the direction v by a Gaussian surface (Eqs. 24-25, with the errata's
    /// exponential): S = (1 - erfc(t) / 2) / (1 + Lambda), t = tau cot theta / (2 sigma),
    /// Lambda = exp(-t^2) / (2 sqrt(pi) t) - erfc(t) / 2.
    fn shadowing(&self, v: [f64; 3]) -> f64 {
        if self.sigma < EPSILON {
            return 1.0;
        }
        let t = self.tau / tan_theta(v) / (2.0 * self.sigma);
        let half_erfc = 0.5 * t.compl_error();
        let lambda = 0.5 / PI.sqrt() / t * (-t * t).exp() - half_erfc;
        (1.0 - half_erfc) / (lambda + 1.0)
    }

    /// The apparent roughness sigma0 = sigma / sqrt(1 + z0^2), z0 the root of z exp(z^2 / 2) = (K_i + K_o) /
    /// sqrt(8 pi), K = tan theta erfc(tau / (2 sigma tan theta)) (Eqs. 80-83), by BBM's 4 Newton steps.
    fn apparent_roughness(&self, wi: [f64; 3], wo: [f64; 3]) -> f64 {
        if self.sigma <= EPSILON {
            return 0.0;
        }
        let k = |w: [f64; 3]| {
            let t = tan_theta(w);
            if t > EPSILON {
                t * (self.tau / (2.0 * self.sigma * t)).compl_error()
            } else {
                0.0
            }
        };
        let f0 = (k(wi) + k(wo)) / (8.0 * PI).sqrt();
        let mut z = if f0 <= 1.0 { f0 } else { (2.0 * f0.ln()).max(0.0).sqrt() };
        for _ in 0..4 {
            let e = (0.5 * z * z).exp();
            let (value, slope) = (z * e - f0, (1.0 + z * z) * e);
            if slope > EPSILON {
                z -= value / slope;
            }
        }
        self.sigma / (1.0 + z * z).max(0.0).sqrt()
    }
}

/// He et al.'s geometrical factor (Eq. 76), (v.v / v_z)^2 P, v = wi + wo, with its polarisation factor
/// P = ((s_r.k_i)^2 + (p_r.k_i)^2) ((s_i.k_r)^2 + (p_i.k_r)^2) / |k_i x k_r|^4 = 1 for unpolarised light:
/// (s_r, p_r, k_r) is an orthonormal basis, so the first factor is 1 - (k_r.k_i)^2 = |k_i x k_r|^2, and the
/// second alike. BBM evaluates P as written, which agrees to rounding except where k_i and k_r are parallel
/// (wi = wo: it takes 1 for G there, a jump from 4 / cos^2 theta_h on MERL's theta_d = 0 row) or one
/// direction is the normal (0 / 0).
fn geometrical(wi: [f64; 3], wo: [f64; 3]) -> f64 {
    let v = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    ((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / v[2]).powi(2)
}

/// A grid of roughnesses and correlation lengths, a metal-like index (F0 = 0.61, as the microfacet
/// models'), a dark or a bright base.
pub(crate) fn starts() -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    for sigma in [0.01, 0.03, 0.1, 0.3] {
        for tau in [0.3, 1.0, 3.0, 10.0] {
            for kd in [0.02, 0.2] {
                out.push([vec![sigma, tau], vec![1.5; 3], vec![3.0; 3], vec![kd; 3]].concat());
            }
        }
    }
    out
}
