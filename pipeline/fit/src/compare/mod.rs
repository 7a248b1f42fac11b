//! The comparison models of `twoscale fit --compare` (docs/fit.md "Comparing models"): whether the
//! two-scale model explains a file better than the models papers compare against, answered on the
//! same samples and with the same loss (`problem`'s residuals) as the two-scale fit.
//! - `microfacet`: ggx_lambert, beckmann_lambert and epd_lambert, a conductor coat over a Lambertian
//!   base (epd_lambert is the talk's "Exponential Distribution and Lambert");
//! - `closed`, the models given by a closed form of (wi, wo): `low` (Löw et al. 2012's smooth-surface
//!   model and their ABC microfacet model), `sgd` (Bagher et al. 2012's Shifted Gamma Distribution) and
//!   `he` (He et al. 1991).

mod closed;
mod he;
mod low;
mod microfacet;
mod parameter;
mod sgd;

pub use closed::Values;
pub use he::He;
pub use low::LowSmooth;
pub use microfacet::{Analytic, ALPHA};

use crate::descent::Descended;
use crate::fit::{agreement, Agreement, Samples};
use crate::model::GeneralTables;
use crate::problem::Data;

/// The comparison models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Comparison {
    GgxLambert,
    BeckmannLambert,
    EpdLambert,
    LowSmooth,
    Abc,
    Sgd,
    He,
}

impl Comparison {
    pub const ALL: [Comparison; 7] = [
        Comparison::GgxLambert,
        Comparison::BeckmannLambert,
        Comparison::EpdLambert,
        Comparison::LowSmooth,
        Comparison::Abc,
        Comparison::Sgd,
        Comparison::He,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Comparison::GgxLambert => "ggx_lambert",
            Comparison::BeckmannLambert => "beckmann_lambert",
            Comparison::EpdLambert => "epd_lambert",
            Comparison::LowSmooth => "low_smooth",
            Comparison::Abc => "abc",
            Comparison::Sgd => "sgd",
            Comparison::He => "he",
        }
    }

    /// The numbers fitted (each per-channel parameter counted three times).
    pub fn parameters(self) -> usize {
        match self {
            Comparison::GgxLambert | Comparison::BeckmannLambert | Comparison::EpdLambert => {
                microfacet::parameters(self)
            }
            _ => closed::fitted(self),
        }
    }
}

/// A comparison model's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fitted {
    Microfacet(Analytic),
    Closed(Values),
}

/// A parameter's name and value.
pub type Named = (&'static str, f64);

impl Fitted {
    pub fn model(&self) -> Comparison {
        match self {
            Fitted::Microfacet(a) => a.model,
            Fitted::Closed(v) => v.model,
        }
    }

    /// The parameters by name: those shared by the channels, and each channel's.
    pub fn named(&self) -> (Vec<Named>, [Vec<Named>; 3]) {
        match self {
            Fitted::Microfacet(a) => {
                let shared = microfacet::lobe_names(a.model).iter().zip(a.lobe).map(|(n, v)| (*n, v)).collect();
                (shared, [0, 1, 2].map(|ch| vec![("eta", a.eta[ch]), ("k", a.k[ch]), ("kd", a.kd[ch])]))
            }
            Fitted::Closed(v) => v.named(),
        }
    }
}

/// A comparison model's fit.
#[derive(Clone, Debug)]
pub struct Compared {
    pub params: Fitted,
    /// Sum of squared residuals on the fit subsample.
    pub loss: f64,
    pub evaluations: usize,
    pub termination: String,
    pub agreement: Agreement,
}

/// A comparison model's fit from its final stage (`descent::finish`), logged, with its error over every
/// valid sample of `samples` (`rho(n, ch)` there, at the fitted parameters).
fn compared<S: Copy>(
    samples: &Samples,
    done: Descended<S>,
    fitted: impl FnOnce(S) -> Fitted,
    rho: impl Fn(usize, usize) -> f64 + Sync,
    log: impl Fn(&str),
) -> Compared {
    log(&format!(
        "fit on {} samples, loss {:.4e} ({}, {} evaluations)",
        samples.shared.fit.len(),
        done.loss,
        done.termination,
        done.evaluations
    ));
    Compared {
        params: fitted(done.params),
        loss: done.loss,
        evaluations: done.evaluations,
        termination: done.termination,
        agreement: agreement(samples.all(), rho),
    }
}

/// Fits `model` to `samples` as the two-scale fit does without diffraction: the starts scored on the
/// scout subsample, the best `REFINED` refined there, the best finished on the fit subsample (from it or
/// the best start), then the error over every valid sample. `lambdas`: the channels' wavelengths
/// (micrometres; He et al.'s model depends on them).
pub fn fit_comparison(
    tables: &GeneralTables,
    samples: &Samples,
    model: Comparison,
    lambdas: [f64; 3],
    log: impl Fn(&str),
) -> Compared {
    match model {
        Comparison::GgxLambert | Comparison::BeckmannLambert | Comparison::EpdLambert => {
            microfacet::fit(tables, samples, model, log)
        }
        _ => closed::fit(samples, model, lambdas, log),
    }
}

/// rho per channel of a fitted comparison model at every direction pair of `data`.
pub fn comparison_rho(tables: &GeneralTables, data: &Data, fitted: &Fitted) -> Vec<[f64; 3]> {
    match fitted {
        Fitted::Microfacet(a) => microfacet::analytic_rho(tables, data, a),
        Fitted::Closed(v) => closed::rho_at(data, v),
    }
}
