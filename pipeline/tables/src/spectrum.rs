//! A quantity given per wavelength: a constant, or samples read by linear interpolation in lambda
//! (micrometres), clamped at both ends. Scene files write `x = 0.8` or
//! `x = { wavelengths = [...], values = [...] }`; manifests the same in JSON.

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Spectrum {
    Constant(f64),
    Sampled { wavelengths: Vec<f64>, values: Vec<f64> },
}

impl Spectrum {
    /// The value at lambda (micrometres).
    pub fn at(&self, lambda: f64) -> f64 {
        match self {
            Spectrum::Constant(x) => *x,
            Spectrum::Sampled { wavelengths: w, values: v } => {
                let k = w.partition_point(|&x| x <= lambda);
                if k == 0 {
                    return v[0];
                }
                if k == w.len() {
                    return v[k - 1];
                }
                let t = (lambda - w[k - 1]) / (w[k] - w[k - 1]);
                (1.0 - t) * v[k - 1] + t * v[k]
            }
        }
    }

    /// Every value (one for a constant).
    pub fn values(&self) -> &[f64] {
        match self {
            Spectrum::Constant(x) => std::slice::from_ref(x),
            Spectrum::Sampled { values, .. } => values,
        }
    }

    /// Why this spectrum is malformed, if it is: samples need as many values as wavelengths
    /// (at least one), wavelengths positive and increasing.
    pub fn malformed(&self) -> Option<String> {
        let Spectrum::Sampled { wavelengths: w, values: v } = self else { return None };
        if w.is_empty() || w.len() != v.len() {
            return Some(format!(
                "needs as many values as wavelengths (at least one), got {} and {}",
                v.len(),
                w.len()
            ));
        }
        if w.iter().any(|x| !(x.is_finite() && *x > 0.0)) || w.windows(2).any(|p| p[1] <= p[0]) {
            return Some("wavelengths must be positive and increasing (micrometres)".into());
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_linearly_and_clamps() {
        let s = Spectrum::Sampled { wavelengths: vec![0.4, 0.5, 0.7], values: vec![0.2, 0.4, 0.8] };
        assert_eq!(s.at(0.3), 0.2);
        assert_eq!(s.at(0.9), 0.8);
        assert!((s.at(0.45) - 0.3).abs() < 1e-15);
        assert!((s.at(0.6) - 0.6).abs() < 1e-15);
        assert_eq!(Spectrum::Constant(0.8).at(0.5), 0.8);
        let bad = Spectrum::Sampled { wavelengths: vec![0.5, 0.4], values: vec![0.1, 0.2] };
        assert!(bad.malformed().is_some());
        let parsed: Spectrum = serde_json::from_str(r#"{"wavelengths": [0.4, 0.5], "values": [0.1, 0.2]}"#).unwrap();
        assert_eq!(parsed.at(0.45), 0.15000000000000002);
    }
}
