//! The fit's loss: one residual per sample and channel,
//!
//!   r = w (ln(e_ch + cos_i rho_fit) - ln(e_ch + cos_i rho_measured)),
//!
//! the cosine-weighted BRDF compared in the logarithm (relative error) down to e_ch, below which it is
//! compared linearly (absolute error), each sample weighted by w.
//! - Löw et al. 2012's E2 metric (BBM's `lowLog`) is e = 1, w = 1.
//! - e_ch = `offset` x the channel's mean of cos_i rho over the samples' solid-angle measure: relative to
//!   the file, so that a dark material's diffuse part counts as much as a bright one's.
//! - w^2 = (1 - `sample_share`) m / mean(m) + `sample_share`, m = (the sample's solid-angle measure,
//!   relative to the mean)^`measure_power` x ((cos_i + cos_o) / 2 when `projected`): at power 1 the loss
//!   is an integral over direction pairs, as a renderer's is; at 0, every sample counts alike (a MERL
//!   file's samples crowd the specular peak); the share every sample carries alike keeps the fit from
//!   ignoring the directions a small measure leaves (the grazing mirror direction).
//! - samples at theta_d >= `max_theta_d` are left out (the grazing samples a gonioreflectometer measures
//!   worst).

use crate::measured::Sample;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loss {
    /// e_ch relative to the channel's measure-weighted mean of cos_i rho; None: e = 1 (Löw's).
    pub offset: Option<f64>,
    pub measure_power: f64,
    /// Radians.
    pub max_theta_d: f64,
    /// Each sample weighted by (cos_i + cos_o) / 2 too: the projected area a renderer's pixels see a
    /// surface with, from either direction (a sample stands for both by reciprocity).
    pub projected: bool,
    /// The share of the loss every sample carries alike, whatever its measure: w^2 = (1 - share) (the
    /// weight above, relative to its mean) + share.
    pub sample_share: f64,
}

impl Loss {
    /// The loss `twoscale fit` uses (docs/fit.md "The loss": chosen by the render's SMAPE on half the shared
    /// measured files).
    pub const FIT: Loss =
        Loss { offset: Some(0.1), measure_power: 1.0, max_theta_d: f64::INFINITY, projected: true, sample_share: 0.3 };

    /// Löw et al.'s log metric over every sample.
    pub const LOW: Loss =
        Loss { offset: None, measure_power: 0.0, max_theta_d: f64::INFINITY, projected: false, sample_share: 0.0 };

    /// The same loss with no share spread over the samples alike: every sample by its measure (times the
    /// projected area), an integral over direction pairs as a render's (the fit's second pass).
    pub fn by_measure(&self) -> Loss {
        Loss { sample_share: 0.0, ..*self }
    }

    /// Whether a sample takes part.
    pub fn keeps(&self, s: &Sample) -> bool {
        let h = [s.wi[0] + s.wo[0], s.wi[1] + s.wo[1], s.wi[2] + s.wo[2]];
        let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let cos_d = (s.wi[0] * h[0] + s.wi[1] * h[1] + s.wi[2] * h[2]) / n;
        cos_d.clamp(-1.0, 1.0).acos() < self.max_theta_d
    }

    /// Each sample's weight w^2 in the loss (the header's formula).
    pub fn weights(&self, samples: &[Sample]) -> Vec<f64> {
        let mean = samples.iter().map(|s| s.measure).sum::<f64>() / samples.len().max(1) as f64;
        let solid: Vec<f64> = samples
            .iter()
            .map(|s| {
                let w = if self.measure_power == 0.0 { 1.0 } else { (s.measure / mean).powf(self.measure_power) };
                if self.projected {
                    w * (s.wi[2] + s.wo[2]) / 2.0
                } else {
                    w
                }
            })
            .collect();
        let mean = solid.iter().sum::<f64>() / solid.len().max(1) as f64;
        solid.iter().map(|w| (1.0 - self.sample_share) * w / mean + self.sample_share).collect()
    }

    /// The loss's constants for a file: e per channel, from its samples.
    pub fn scale(&self, samples: &[Sample]) -> Scale {
        let total: f64 = samples.iter().map(|s| s.measure).sum();
        let offset = match self.offset {
            None => [1.0; 3],
            Some(k) => [0, 1, 2].map(|ch| {
                let sum: f64 = samples.iter().map(|s| s.measure * s.wi[2] * s.rho[ch]).sum();
                (k * sum / total).max(1e-12)
            }),
        };
        Scale { offset }
    }
}

/// A loss's constants for one file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    pub offset: [f64; 3],
}

impl Scale {
    /// g(x) = ln(e_ch + x), x = cos_i rho.
    pub fn compress(&self, x: f64, ch: usize) -> f64 {
        (self.offset[ch] + x).ln()
    }
}
