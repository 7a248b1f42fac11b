//! Derived axes and encoded values (docs/maths.md section 4b): a table may store one
//! axis in a coordinate computed from the physical ones, and a value in an
//! encoding; the manifest states both formulas, and every reader (this
//! crate's lookup, the Python reader, the C header) applies them the same way.

use crate::lobe::Term;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, LN_2};

/// A stored axis computed from physical coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Derivation {
    /// The angle of a lobe in two pieces joined at its closed-form edge
    /// (zh_lobe; inputs u, p, beta): theta_a = min(sqrt(1 / (1 + 4 u^2) + atan(beta k^(1/(2p)))^2),
    /// theta_cap), the diffraction lobe's width (sin theta = 1/(2u), 1 at u = 0)
    /// combined with the angle at which the EPD has fallen to e^-k (k = ln 1e4:
    /// the 1e-4 level). Inside the edge v = v_a ln(1 + theta_h/theta_a) / ln 2,
    /// beyond it v = v_a + (1 - v_a) ln(theta_h/theta_a) / ln((pi/2)/theta_a):
    /// the edge sits at v = v_a for every node, so interpolating across beta
    /// and p does not smear it, and the tail is spaced logarithmically. The
    /// cap keeps the outer piece at least ln((pi/2)/theta_cap) wide.
    AnchoredLobeAngle { k: f64, v_anchor: f64, theta_cap: f64 },
    /// The same angle within one material (beta and p fixed, its per-material
    /// `zh_lobe`): the EPD's edge angle `edge_d` = atan(beta k^(1/(2p))) is a
    /// number, and the edge theta_a(u) = min(sqrt(1 / (1 + 4 u^2) + edge_d^2),
    /// theta_cap) depends on u alone.
    MaterialLobeAngle { edge_d: f64, v_anchor: f64, theta_cap: f64 },
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
    /// The physical coordinates the formula reads, in the order of its arguments.
    pub fn inputs(&self) -> Vec<String> {
        let names: &[&str] = match self {
            Derivation::AnchoredLobeAngle { .. } => &["u", "p", "beta"],
            Derivation::MaterialLobeAngle { .. } => &["u"],
        };
        names.iter().map(|n| n.to_string()).collect()
    }

    /// The closed-form lobe edge theta_a from the inputs: (u, p, beta), or (u) within a material.
    pub fn anchor(&self, inputs: &[f64]) -> f64 {
        let u = inputs[0];
        let (wd, theta_cap) = match *self {
            Derivation::AnchoredLobeAngle { k, theta_cap, .. } => {
                ((inputs[2] * k.powf(0.5 / inputs[1])).atan(), theta_cap)
            }
            Derivation::MaterialLobeAngle { edge_d, theta_cap, .. } => (edge_d, theta_cap),
        };
        (1.0 / (1.0 + 4.0 * u * u) + wd * wd).sqrt().min(theta_cap)
    }

    fn v_anchor(&self) -> f64 {
        match *self {
            Derivation::AnchoredLobeAngle { v_anchor, .. } | Derivation::MaterialLobeAngle { v_anchor, .. } => v_anchor,
        }
    }

    /// The stored coordinate v of `theta` for the inputs (see `anchor`).
    pub fn forward(&self, theta: f64, inputs: &[f64]) -> f64 {
        let va = self.v_anchor();
        let ta = self.anchor(inputs);
        if theta <= ta {
            va * (theta / ta).ln_1p() / LN_2
        } else {
            va + (1.0 - va) * (theta / ta).ln() / (FRAC_PI_2 / ta).ln()
        }
    }

    /// The angle at stored coordinate v (inverse of `forward`).
    pub fn inverse(&self, v: f64, inputs: &[f64]) -> f64 {
        let va = self.v_anchor();
        let ta = self.anchor(inputs);
        let theta = if v <= va {
            ta * (v / va * LN_2).exp_m1()
        } else {
            ta * ((v - va) / (1.0 - va) * (FRAC_PI_2 / ta).ln()).exp()
        };
        theta.min(FRAC_PI_2)
    }

    /// The manifest's entry of this derivation of stored axis `axis` from `coordinate`, its formula as text.
    pub fn describe(&self, axis: &str, coordinate: &str) -> DerivedAxis {
        let edge = match *self {
            Derivation::AnchoredLobeAngle { k, theta_cap, .. } => {
                format!("min(sqrt(1/(1 + 4 u^2) + atan(beta * {k:?}^(1/(2 p)))^2), {theta_cap:?})")
            }
            Derivation::MaterialLobeAngle { edge_d, theta_cap, .. } => {
                format!("min(sqrt(1/(1 + 4 u^2) + {edge_d:?}^2), {theta_cap:?})")
            }
        };
        let va = self.v_anchor();
        DerivedAxis {
            axis: axis.into(),
            coordinate: coordinate.into(),
            min: 0.0,
            max: FRAC_PI_2,
            inputs: self.inputs(),
            derivation: *self,
            formula: format!(
                "a = {edge}; {axis} = {va:?} * ln(1 + {coordinate}/a) / ln(2) if {coordinate} <= a, \
                 else {va:?} + (1 - {va:?}) * ln({coordinate}/a) / ln((pi/2)/a)"
            ),
        }
    }
}

/// What a table states beside its data: its derived axes and encoded values (both empty for
/// a table stored in physical coordinates and values), and its interpolation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Derived {
    pub axes: Vec<DerivedAxis>,
    pub values: Vec<EncodedValue>,
    pub interpolation: crate::interp::Interpolation,
}

/// How a stored value encodes the physical one: the one kind of the contract.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ValueEncoding {
    /// stored = ln(value) at the nodes; value = exp(I[stored] + sum_j
    /// alpha_j (t_j - I[cv_j])) with the control variates of `EncodedValue`
    /// (none: exp of the interpolated ln; zh_lobe: `lobe`).
    Ln,
}

/// One control variate of an encoded value: the term and the stored values holding it at the nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControlVariate {
    pub term: Term,
    pub values: String,
}

/// A value stored in an encoding, and the formula as text.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EncodedValue {
    pub value: String,
    #[serde(flatten)]
    pub encoding: ValueEncoding,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub control_variates: Vec<ControlVariate>,
    pub formula: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_encoded_value_reads_as_the_manifest_writes_it() {
        let lobe = r#"{"value": "c_lobe", "kind": "ln", "control_variates": [{"term": "b", "values": "cv_b"}], "formula": "f"}"#;
        let e: EncodedValue = serde_json::from_str(lobe).unwrap();
        assert_eq!(e.control_variates, [ControlVariate { term: Term::B, values: "cv_b".into() }]);
        let plain: EncodedValue = serde_json::from_str(r#"{"value": "r", "kind": "ln", "formula": "f"}"#).unwrap();
        assert!(plain.control_variates.is_empty());
        assert!(!serde_json::to_string(&plain).unwrap().contains("control_variates"));
        // The kinds of 0.5.0 to 0.8.0 are no longer read.
        assert!(serde_json::from_str::<EncodedValue>(
            r#"{"value": "c", "kind": "ln_control_variates_epd", "formula": "f"}"#
        )
        .is_err());
    }

    #[test]
    fn lobe_angle_round_trips_and_spans_the_quarter_circle() {
        let d = Derivation::AnchoredLobeAngle { k: 1e4f64.ln(), v_anchor: 0.5, theta_cap: 1.45 };
        for &(u, p, beta) in
            &[(0.0, 0.2, 0.005), (100.0, 5.0, 0.005), (3.0, 1.0, 0.5), (100.0, 0.2, 0.5), (0.0, 0.2, 0.5)]
        {
            let inputs = [u, p, beta];
            assert_eq!(d.forward(0.0, &inputs), 0.0);
            assert!((d.forward(FRAC_PI_2, &inputs) - 1.0).abs() < 1e-15);
            // The edge is at v_anchor, approached continuously from both pieces.
            let a = d.anchor(&inputs);
            assert!(a > 0.0 && a <= 1.45);
            assert!((d.forward(a, &inputs) - 0.5).abs() < 1e-15);
            assert!((d.forward(a * (1.0 + 1e-9), &inputs) - 0.5).abs() < 1e-8);
            for &th in &[1e-6, 0.01, 0.3, 1.2, 1.57] {
                let back = d.inverse(d.forward(th, &inputs), &inputs);
                assert!((back - th).abs() <= 1e-12 * th.max(1e-3), "{u} {p} {beta} {th} {back}");
            }
        }
    }
}
