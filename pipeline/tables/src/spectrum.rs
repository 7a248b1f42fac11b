//! A quantity given per wavelength: a constant, or samples that runtimes read by linear interpolation
//! in lambda (micrometres), clamped at both ends. Scene files write `x = 0.8` or
//! `x = { wavelengths = [...], values = [...] }`; manifests the same in JSON.

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Spectrum {
    Constant(f64),
    Sampled { wavelengths: Vec<f64>, values: Vec<f64> },
}

impl Spectrum {
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
    fn parses_both_forms_and_names_what_is_malformed() {
        let parsed: Spectrum = serde_json::from_str(r#"{"wavelengths": [0.4, 0.5], "values": [0.1, 0.2]}"#).unwrap();
        assert_eq!(parsed, Spectrum::Sampled { wavelengths: vec![0.4, 0.5], values: vec![0.1, 0.2] });
        assert_eq!(serde_json::from_str::<Spectrum>("0.8").unwrap().values(), [0.8]);
        assert!(parsed.malformed().is_none());
        let bad = Spectrum::Sampled { wavelengths: vec![0.5, 0.4], values: vec![0.1, 0.2] };
        assert!(bad.malformed().unwrap().contains("increasing"));
        let short = Spectrum::Sampled { wavelengths: vec![0.5], values: vec![0.1, 0.2] };
        assert!(short.malformed().unwrap().contains("as many values"));
    }
}
