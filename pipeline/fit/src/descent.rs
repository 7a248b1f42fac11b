//! The descent every fit shares, two-scale and comparison models alike (docs/fit.md "The method"): starts
//! scored by their loss, the best refined by Levenberg-Marquardt on the scout subsample (`scout`), then
//! LM on the fit subsample from the better of that refinement and the best start (`finish`). A model's
//! least-squares problem implements `Descent`; this module knows no model.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::Dyn;

/// A least-squares problem LM descends, with its sum of squared residuals and current parameters.
pub(crate) trait Descent<S>: LeastSquaresProblem<f64, Dyn, Dyn> {
    fn loss(&self) -> f64;
    fn current(&self) -> S;
    fn evaluations(&self) -> usize;

    /// MINPACK's factor of the first step's bound (its default, 100, scaled by the coordinates' size).
    fn step_bound(&self) -> f64 {
        100.0
    }
}

/// Where LM ended: parameters, loss, model evaluations and how it stopped.
pub(crate) struct Descended<S> {
    pub params: S,
    pub loss: f64,
    pub evaluations: usize,
    pub termination: String,
}

/// MINPACK stops where an iteration lowers the loss by less than this, relatively (both the actual
/// and the predicted reduction). Its default, 1.5e-8, let the diffracting subsurface model crawl
/// 190 more evaluations (59 s) for 0.4 % of loss on a file outside its family (the EPD coat of
/// out_of_family.py); 1e-6 gave the same renders on the shared measured files as 1e-4, in 1.4 times
/// the time, and the same synthetic recoveries (docs/fit.md).
const FTOL: f64 = 1e-4;

/// LM from the best of `starts` (`problem` makes the problem at a start). Where it ends worse than
/// that start (or on non-finite residuals, where MINPACK leaves the problem at its last trial step),
/// the start is kept: a fit never ends worse, in its own loss, than its best start.
fn descend<S: Copy, P: Descent<S>>(starts: &[S], problem: impl Fn(&S) -> P, patience: usize) -> Descended<S> {
    let (start_loss, start) = starts
        .iter()
        .map(|s| {
            let p = problem(s);
            (p.loss(), p)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("a start");
    let from = start.current();
    let lm = LevenbergMarquardt::new().with_patience(patience).with_ftol(FTOL).with_stepbound(start.step_bound());
    let (ended, report) = lm.minimize(start);
    let loss = ended.loss();
    let evaluations = ended.evaluations();
    if loss <= start_loss {
        Descended { params: ended.current(), loss, evaluations, termination: format!("{:?}", report.termination) }
    } else {
        let termination = format!("kept the start: LM ended at loss {loss:.4e} ({:?})", report.termination);
        Descended { params: from, loss: start_loss, evaluations, termination }
    }
}

/// LM's patience (MINPACK's: at most patience (n + 1) evaluations, n parameters) on the scout
/// subsample and on the fit subsample.
const SCOUT_PATIENCE: usize = 6;
const FIT_PATIENCE: usize = 20;

/// The scout stage, for the two-scale and the comparison models alike: `starts` scored by their loss
/// (`problem` makes the problem at a start on the scout subsample), the best `keep` refined by LM.
/// The best refinement, and the best start: the final stage starts from either, since the
/// refinement is better on the scout's samples only.
pub(crate) fn scout<S: Copy, P: Descent<S>>(
    starts: Vec<S>,
    problem: impl Fn(&S) -> P,
    keep: usize,
) -> (Descended<S>, S) {
    let mut scored: Vec<(f64, S)> = starts.into_iter().map(|s| (problem(&s).loss(), s)).collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let refined = scored
        .iter()
        .take(keep)
        .map(|(_, s)| descend(std::slice::from_ref(s), &problem, SCOUT_PATIENCE))
        .min_by(|a, b| a.loss.total_cmp(&b.loss))
        .expect("a start");
    (refined, scored[0].1)
}

/// The final stage: LM on the fit subsample from the better of the scout's refinement and the best start.
pub(crate) fn finish<S: Copy, P: Descent<S>>(from: (Descended<S>, S), problem: impl Fn(&S) -> P) -> Descended<S> {
    descend(&[from.0.params, from.1], problem, FIT_PATIENCE)
}
