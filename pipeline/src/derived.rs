//! Derived axes and encoded values (SPEC section 4b): a table may store one
//! axis in a coordinate computed from the physical ones, and a value in an
//! encoding; the manifest states both formulas, and every reader (this
//! crate's lookup, the Python reader, the C header) applies them the same way.

use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// A stored axis computed from physical coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Derivation {
    /// The angle of a lobe scaled by its closed-form width (zh_lobe):
    /// w = sqrt(1 / (1 + 4 u^2) + (beta k^(1/(2p)))^2), the diffraction lobe's
    /// width (sin theta = 1/(2u), capped at 1 for u = 0) combined with the
    /// width at which the EPD has fallen to e^-k (k = ln 1e4: the 1e-4 level,
    /// so that its edge sits at one coordinate for every p);
    /// v = ln(1 + theta_h / w) / ln(1 + (pi/2) / w), 0 at theta_h = 0 and 1 at pi/2.
    LobeAngle { k: f64 },
}

/// One derived axis: the stored axis `axis` is computed from the physical
/// coordinate `coordinate` (within [min, max]) and the coordinates `inputs`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DerivedAxis {
    pub axis: String,
    pub coordinate: String,
    pub min: f64,
    pub max: f64,
    /// The physical coordinates the formula reads, in the order of its arguments.
    pub inputs: Vec<String>,
    #[serde(flatten)]
    pub derivation: Derivation,
    pub formula: String,
}

impl Derivation {
    /// The closed-form lobe width w(u, beta, p).
    pub fn width(&self, u: f64, beta: f64, p: f64) -> f64 {
        match *self {
            Derivation::LobeAngle { k } => {
                let wd = beta * k.powf(0.5 / p);
                (1.0 / (1.0 + 4.0 * u * u) + wd * wd).sqrt()
            }
        }
    }

    /// The stored coordinate v of `theta` for inputs (u, beta, p).
    pub fn forward(&self, theta: f64, inputs: &[f64]) -> f64 {
        let w = self.width(inputs[0], inputs[1], inputs[2]);
        (theta / w).ln_1p() / (FRAC_PI_2 / w).ln_1p()
    }

    /// The angle at stored coordinate v (inverse of `forward`).
    pub fn inverse(&self, v: f64, inputs: &[f64]) -> f64 {
        let w = self.width(inputs[0], inputs[1], inputs[2]);
        (w * (v * (FRAC_PI_2 / w).ln_1p()).exp_m1()).min(FRAC_PI_2)
    }

    pub fn describe(&self, axis: &str, coordinate: &str) -> DerivedAxis {
        match *self {
            Derivation::LobeAngle { k } => DerivedAxis {
                axis: axis.into(),
                coordinate: coordinate.into(),
                min: 0.0,
                max: FRAC_PI_2,
                inputs: vec!["u".into(), "beta".into(), "p".into()],
                derivation: *self,
                formula: format!(
                    "w = sqrt(1/(1 + 4 u^2) + (beta * {k:?}^(1/(2 p)))^2); \
                     {axis} = ln(1 + {coordinate}/w) / ln(1 + (pi/2)/w)"
                ),
            },
        }
    }
}

/// What a table derives: its derived axes and encoded values (both empty for
/// a table stored in physical coordinates and values).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Derived {
    pub axes: Vec<DerivedAxis>,
    pub values: Vec<ValueEncoding>,
}

/// How a stored value encodes the physical one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Encoding {
    /// stored = ln(value); value = exp(stored), interpolated in the stored form.
    Ln,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValueEncoding {
    pub value: String,
    #[serde(flatten)]
    pub encoding: Encoding,
    pub formula: String,
}

impl Encoding {
    pub fn encode(&self, x: f64) -> f64 {
        match self {
            Encoding::Ln => x.ln(),
        }
    }

    pub fn decode(&self, stored: f64) -> f64 {
        match self {
            Encoding::Ln => stored.exp(),
        }
    }

    pub fn describe(&self, value: &str) -> ValueEncoding {
        match self {
            Encoding::Ln => ValueEncoding {
                value: value.into(),
                encoding: *self,
                formula: format!("{value} = exp(stored {value}), the stored value interpolated multilinearly first"),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_angle_round_trips_and_spans_the_quarter_circle() {
        let d = Derivation::LobeAngle { k: 1e4f64.ln() };
        for &(u, beta, p) in &[(0.0, 0.005, 0.2), (100.0, 0.005, 5.0), (3.0, 0.5, 1.0), (100.0, 0.5, 0.2)] {
            let inputs = [u, beta, p];
            assert_eq!(d.forward(0.0, &inputs), 0.0);
            assert!((d.forward(FRAC_PI_2, &inputs) - 1.0).abs() < 1e-15);
            for &th in &[1e-6, 0.01, 0.3, 1.2, 1.57] {
                let back = d.inverse(d.forward(th, &inputs), &inputs);
                assert!((back - th).abs() <= 1e-12 * th.max(1e-3), "{u} {beta} {p} {th} {back}");
            }
        }
    }
}
