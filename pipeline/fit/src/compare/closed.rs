//! The comparison models given by a closed form of (wi, wo), fitted by one least-squares problem: each
//! model lists its parameters (a name, the channel it belongs to, its range), evaluates rho from their
//! values, and gives its starts; LM moves the parameters' unbounded coordinates (`params::Range`), with
//! `problem`'s residuals and a forward-difference Jacobian.

use super::parameter::Parameter;
use super::{he, low, sgd, Compared, Comparison, Fitted, Named};
use crate::descent::{finish, scout, Descent};
use crate::fit::{Samples, REFINED};
use crate::params::Range;
use crate::problem::{Data, STEP};
use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;

/// The most parameters a model has (SGD's 11 per channel, 18 of them fitted).
const MAX: usize = 33;

/// A closed-form model's parameters: their values in the order `parameters(model)` lists them, and the
/// channels' wavelengths (micrometres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Values {
    pub model: Comparison,
    pub lambdas: [f64; 3],
    v: [f64; MAX],
}

impl Values {
    /// Panics unless `values` has as many numbers as the model has parameters.
    pub fn new(model: Comparison, lambdas: [f64; 3], values: &[f64]) -> Values {
        assert_eq!(values.len(), parameters(model).len(), "{}'s parameters", model.name());
        let mut v = [0.0; MAX];
        v[..values.len()].copy_from_slice(values);
        Values { model, lambdas, v }
    }

    /// The values, in `parameters(model)`'s order.
    pub fn values(&self) -> &[f64] {
        &self.v[..parameters(self.model).len()]
    }

    /// The BRDF (1/sr) for the directions to the light `wi` and to the viewer `wo` (unit vectors, z the
    /// normal).
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let v = self.values();
        match self.model {
            Comparison::LowSmooth => low::smooth(v).rho(wi, wo),
            Comparison::Abc => low::abc(v).rho(wi, wo),
            Comparison::Sgd => sgd::sgd(v).rho(wi, wo),
            Comparison::He => he::he(v).rho(wi, wo, self.lambdas),
            _ => unreachable!("{} is not a closed form", self.model.name()),
        }
    }

    pub(crate) fn named(&self) -> (Vec<Named>, [Vec<Named>; 3]) {
        let mut out = (Vec::new(), [Vec::new(), Vec::new(), Vec::new()]);
        for (p, &v) in parameters(self.model).iter().zip(self.values()) {
            match p.channel {
                None => out.0.push((p.name, v)),
                Some(ch) => out.1[ch].push((p.name, v)),
            }
        }
        out
    }
}

/// The numbers fitted.
pub(crate) fn fitted(model: Comparison) -> usize {
    parameters(model).iter().filter(|p| p.range.is_some()).count()
}

/// A closed-form model's parameters.
pub(crate) fn parameters(model: Comparison) -> &'static [Parameter] {
    match model {
        Comparison::LowSmooth => &low::SMOOTH,
        Comparison::Abc => &low::ABC,
        Comparison::Sgd => &sgd::PARAMETERS,
        Comparison::He => &he::PARAMETERS,
        _ => unreachable!("{} is not a closed form", model.name()),
    }
}

fn starts(model: Comparison) -> Vec<Vec<f64>> {
    match model {
        Comparison::LowSmooth => low::smooth_starts(),
        Comparison::Abc => low::abc_starts(),
        Comparison::Sgd => sgd::starts(),
        Comparison::He => he::starts(),
        _ => unreachable!("{} is not a closed form", model.name()),
    }
}

/// Each sample's direction pair (an isotropic model's value at the pair of `Geometry::directions`).
fn pairs(data: &Data) -> Vec<([f64; 3], [f64; 3])> {
    data.geometry.par_iter().map(|g| g.directions()).collect()
}

/// rho at every direction pair of `data`.
pub(crate) fn rho_at(data: &Data, values: &Values) -> Vec<[f64; 3]> {
    pairs(data).par_iter().map(|&(wi, wo)| values.rho(wi, wo)).collect()
}

struct ClosedProblem<'a> {
    data: &'a Data,
    pairs: &'a [([f64; 3], [f64; 3])],
    x: DVector<f64>,
    values: Values,
    /// rho at each sample at the current values.
    rho: Vec<[f64; 3]>,
    evaluations: usize,
}

impl<'a> ClosedProblem<'a> {
    /// x: the fitted parameters' coordinates, in their order.
    fn new(data: &'a Data, pairs: &'a [([f64; 3], [f64; 3])], start: &Values) -> ClosedProblem<'a> {
        let ranges = parameters(start.model).iter().zip(start.values());
        let x = ranges.filter_map(|(p, &v)| p.range.map(|r| r.x(v))).collect();
        let mut p =
            ClosedProblem { data, pairs, x: DVector::zeros(0), values: *start, rho: Vec::new(), evaluations: 0 };
        p.set_params(&DVector::from_vec(x));
        p
    }

    /// The fitted parameters (with their ranges) and their indices among the model's.
    fn fitted(&self) -> impl Iterator<Item = (usize, &'static Parameter, Range)> {
        let all = parameters(self.values.model).iter().enumerate();
        all.filter_map(|(i, p)| p.range.map(|r| (i, p, r)))
    }

    fn values_at(&self, x: &[f64]) -> Values {
        let mut values = self.values;
        for ((i, _, range), &x) in self.fitted().zip(x) {
            values.v[i] = range.value(x);
        }
        values
    }

    fn rho_of(&self, values: &Values) -> Vec<[f64; 3]> {
        self.pairs.par_iter().map(|&(wi, wo)| values.rho(wi, wo)).collect()
    }

    /// The residuals of `rho`, of values clamped at 0 (a model may dip below it: SGD's F where f1 > f0,
    /// and g = ln(e + x) has no value below -e).
    fn residuals_of(&self, rho: &[[f64; 3]]) -> Vec<f64> {
        (0..3 * self.data.len())
            .into_par_iter()
            .map(|i| self.data.residual(i / 3, i % 3, rho[i / 3][i % 3].max(0.0)))
            .collect()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for ClosedProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x = x.clone();
        self.values = self.values_at(x.as_slice());
        self.rho = self.rho_of(&self.values);
        self.evaluations += 1;
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.residuals_of(&self.rho);
        r.iter().all(|v| v.is_finite()).then(|| DVector::from_vec(r))
    }

    /// Forward differences; a channel's parameter moves that channel's residuals only.
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let r0 = self.residuals_of(&self.rho);
        let mut jac = DMatrix::zeros(r0.len(), self.x.len());
        for (col, (_, p, _)) in self.fitted().enumerate() {
            let mut x = self.x.clone();
            x[col] += STEP;
            let r = self.residuals_of(&self.rho_of(&self.values_at(x.as_slice())));
            for (row, (a, b)) in r.iter().zip(&r0).enumerate() {
                if p.channel.is_none_or(|ch| row % 3 == ch) {
                    jac[(row, col)] = (a - b) / STEP;
                }
            }
        }
        jac.iter().all(|v| v.is_finite()).then_some(jac)
    }
}

impl Descent<Values> for ClosedProblem<'_> {
    fn loss(&self) -> f64 {
        self.residuals_of(&self.rho).iter().map(|r| r * r).sum()
    }

    fn current(&self) -> Values {
        self.values
    }

    fn evaluations(&self) -> usize {
        self.evaluations
    }

    fn step_bound(&self) -> f64 {
        STEP_BOUND
    }
}

/// MINPACK's first step bound for these models, 1e-4 of its default: from a start far off (He et al.'s
/// lobe at a wrong roughness is orders of magnitude off), the first Gauss-Newton step took every kd to
/// its logistic coordinate's saturation (x ~ 35), where its gradient vanishes, and LM stopped there (He's
/// own file fitted to 5e-3 relative RMS; 2e-12 with this bound; 1.0 changed nothing).
const STEP_BOUND: f64 = 0.01;

/// Fits the closed-form `model` to `samples` as `super::fit_comparison` says.
pub(crate) fn fit(samples: &Samples, model: Comparison, lambdas: [f64; 3], log: impl Fn(&str)) -> Compared {
    let (scout_pairs, fit_pairs) = (pairs(&samples.shared.scout), pairs(&samples.shared.fit));
    let starts: Vec<Values> = starts(model).iter().map(|v| Values::new(model, lambdas, v)).collect();
    let scouted = scout(starts, |v| ClosedProblem::new(&samples.shared.scout, &scout_pairs, v), REFINED);
    log(&format!("scout fit on {} samples, loss {:.4e}", samples.shared.scout.len(), scouted.0.loss));
    let done = finish(scouted, |v| ClosedProblem::new(&samples.shared.fit, &fit_pairs, v));
    let rho = rho_at(samples.all(), &done.params);
    super::compared(samples, done, Fitted::Closed, |n, ch| rho[n][ch], log)
}
