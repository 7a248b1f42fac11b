//! The fit (docs/fit.md): starts scored on a small subsample, Levenberg-Marquardt from the best
//! on a larger one, with and without a diffraction part, then the error over every valid sample.

use crate::descent::{finish, scout, Descended};
use crate::layer::{Beneath, Quadrature};
use crate::loss::{Loss, Scale};
use crate::measured::{Measured, Sample};
use crate::model::{Domain, GeneralTables, Geometry, Surface};
use crate::params::{AtBound, Coordinates, Model, Params, Under, IOR};
use crate::problem::{rho, Data, Problem};
use rayon::prelude::*;
use serde::Serialize;

/// What the fit takes besides the samples.
#[derive(Clone, Debug)]
pub struct FitOptions {
    pub model: Model,
    /// The channels' wavelengths (micrometres), red, green, blue.
    pub lambdas: [f64; 3],
    /// The range of B = b / lambda the fit may use, within the general tables' (a scene file's
    /// range, so that `twoscale build --scene` takes what the fit writes).
    pub b_over_lambda: (f64, f64),
    /// How many of the best scored starts are refined on the scout subsample (`REFINED`; more to
    /// measure what the grid's other starts would give: pipeline/fit/examples/starts.rs).
    pub refined_starts: usize,
    /// The mean squared residual of the best model already fitted, when the fit picks among models
    /// (`--model auto`): a model `RIVAL` times above it even with diffraction on the scout subsample
    /// does not have its diffracting stage finished (its candidate without diffraction still goes to the
    /// render that chooses the model).
    pub rival: Option<f64>,
}

/// How far above a rival's mean squared residual a model's diffracting stage is not worth finishing: a
/// speed heuristic (a plastic's diffracting stage took 18 s on a metal it fitted 10^5 times worse), not a
/// choice; `--model auto` chooses by the render among the candidates that are finished.
pub const RIVAL: f64 = 10.0;

/// The starts refined on the scout subsample: the best of the grid (the best two gave the same renders on
/// the shared measured files at 1.4 times the time, and every start refined the same fits on the files
/// outside the family: docs/fit.md).
pub const REFINED: usize = 1;

/// The scout subsample's size (at most the fit subsample's): enough to rank the starts and decide whether
/// diffraction helps, a fraction of a fit's cost.
pub const SCOUT_SAMPLES: usize = 4000;

/// How a pass of the fit weighs the samples (docs/fit.md "The loss").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Weighting {
    /// The loss's own weights (`Loss::FIT`): 70 % by measure, 30 % alike, which holds the specular peak.
    Shared,
    /// By the measure alone (`Loss::by_measure`): the integral over direction pairs a render takes.
    Measure,
}

/// The subsamples of one pass: the scout's and the fit's.
pub struct Pass {
    pub scout: Data,
    pub fit: Data,
}

/// The by-measure pass draws 1/MEASURE_SHARE of the shared pass's samples (scout and fit): on the 25 MERL files
/// the loss was chosen on, the same renders as with as many (at or below ABC's on 19 either way, median SMAPE /
/// ABC's 0.69 against 0.71, the render then choosing among all four candidates) in 0.8 times the fits' time
/// (docs/fit.md "The loss").
pub const MEASURE_SHARE: usize = 2;

/// A file's samples as every model's fit uses them: each pass's subsamples and all of them (the same for
/// every model, so that `--compare` compares on the same samples; the comparison models take the shared pass).
pub struct Samples {
    pub shared: Pass,
    pub by_measure: Pass,
    /// Every valid sample; None where the fit subsample holds them all (`--samples all`).
    all: Option<Data>,
}

impl Samples {
    /// `fit_samples` (None: every one) and `SCOUT_SAMPLES` drawn from `measured` by a hash of the bin.
    pub fn new(measured: &Measured, loss: &Loss, fit_samples: Option<usize>) -> Samples {
        let scout_samples = fit_samples.unwrap_or(usize::MAX).min(SCOUT_SAMPLES);
        let kept: Vec<Sample> = measured.samples.iter().filter(|s| loss.keeps(s)).copied().collect();
        let scale = loss.scale(&kept);
        let of = |(samples, weights): (Vec<Sample>, Vec<f64>)| data(&samples, &weights, &measured.nodes, scale);
        let pass = |loss: &Loss, salt: u64, share: usize| {
            let weights = loss.weights(&kept);
            Pass {
                scout: of(subsample(&kept, &weights, Some(scout_samples / share), salt)),
                fit: of(subsample(&kept, &weights, fit_samples.map(|n| n / share), salt + 1)),
            }
        };
        let shared = pass(loss, 1, 1);
        let all = (shared.fit.len() < measured.samples.len())
            .then(|| data(&measured.samples, &vec![1.0; measured.samples.len()], &measured.nodes, scale));
        Samples { shared, by_measure: pass(&loss.by_measure(), 3, MEASURE_SHARE), all }
    }

    pub fn all(&self) -> &Data {
        self.all.as_ref().unwrap_or(&self.shared.fit)
    }
}

/// How well a fit matches the measured samples, over all of them.
#[derive(Clone, Debug, Serialize)]
pub struct Agreement {
    /// sqrt(sum (f - t)^2 / sum t^2), f and t the fitted and measured rho cos theta_i, all channels.
    pub relative_rms: f64,
    /// The same per channel (red, green, blue).
    pub relative_rms_per_channel: [f64; 3],
    /// The RMS of ln(1 + cos_i rho_fit) - ln(1 + cos_i rho_measured) (Löw et al.'s E2 metric, whatever the
    /// loss fitted), of values clamped at 0.
    pub log_rms: f64,
    /// The same of rho = 0, RMS ln(1 + cos_i rho_measured): what `log_rms` compares with.
    pub log_rms_of_zero: f64,
    /// The valid samples compared.
    pub samples: usize,
}

/// One candidate's fit.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub params: Params,
    pub diffraction: bool,
    /// The pass that fitted it.
    pub weighting: Weighting,
    /// Its pass's fit subsample's size.
    pub samples: usize,
    /// Sum of squared residuals on its pass's fit subsample.
    pub loss: f64,
    pub evaluations: usize,
    pub termination: String,
    /// Its parameters at an end of their range (`Coordinates::at_ends`).
    pub at_ends: Vec<AtBound>,
}

/// The fit's result.
#[derive(Clone, Debug)]
pub struct Fit {
    pub model: Model,
    pub best: Candidate,
    /// Every candidate fitted on the fit subsample: without diffraction, and with it where it fitted
    /// better on the scout subsample.
    pub candidates: Vec<Candidate>,
    pub fit_samples: usize,
    /// The parameters' domain the fit used.
    pub domain: Domain,
}

/// SplitMix64's finaliser: a hash of the bin that draws the subsamples without aliasing the grid.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// About `n` of the samples, each drawn with a probability p proportional to its weight in the loss
/// (capped at 1), and its weight divided by p: the subsample's loss estimates the whole file's without
/// bias, with its samples where the loss weighs (uniformly in solid angle, where the weights are the
/// measure). The same ones for the same file whatever the thread count (a hash of the sample's key).
fn subsample(samples: &[Sample], weights: &[f64], n: Option<usize>, salt: u64) -> (Vec<Sample>, Vec<f64>) {
    let Some(n) = n.filter(|&n| n < samples.len()) else { return (samples.to_vec(), weights.to_vec()) };
    // p = min(1, c w): c such that the expected count sum p is n (bisection in ln c, to 120 / 2^60)
    let count = |c: f64| weights.iter().map(|w| (c * w).min(1.0)).sum::<f64>();
    let (mut lo, mut hi) = (-60.0f64, 60.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if count(mid.exp()) < n as f64 {
            lo = mid
        } else {
            hi = mid
        }
    }
    let c = hi.exp();
    let mut drawn = (Vec::new(), Vec::new());
    for (s, w) in samples.iter().zip(weights) {
        let p = (c * w).min(1.0);
        if (mix(s.key ^ salt) as f64) < p * u64::MAX as f64 {
            drawn.0.push(*s);
            drawn.1.push(w / p);
        }
    }
    // the weights' mean 1: the loss's scale is a subsample's size's
    let mean = drawn.1.iter().sum::<f64>() / drawn.1.len().max(1) as f64;
    drawn.1.iter_mut().for_each(|w| *w /= mean);
    drawn
}

fn data(samples: &[Sample], weights: &[f64], nodes: &[(f64, f64)], scale: Scale) -> Data {
    let geometry: Vec<Geometry> = samples.par_iter().map(|s| Geometry::of(s.wi, s.wo, s.node as usize)).collect();
    let rho: Vec<[f64; 3]> = samples.iter().map(|s| s.rho).collect();
    Data::new(geometry, nodes.to_vec(), &rho, weights, scale)
}

/// A start without diffraction: an EPD, and a metal-like index (F0 = 0.61), a grey layer or a
/// bright isotropic medium.
fn start(model: Model, lambdas: [f64; 3], beta: f64, p: f64) -> Params {
    let surface = Surface { beta, p, sigma_s: 0.0, b: 1.0, c: 2.0 };
    let under = match model {
        Model::Conductor => Under::Conductor { eta: [1.5; 3], k: [3.0; 3] },
        Model::Plastic => Under::Layered { ior: 1.5, beneath: Beneath::Diffuse { diffuse: [0.5; 3] } },
        Model::Subsurface => Under::Layered { ior: 1.5, beneath: Beneath::Medium { albedo: [0.9; 3], g: 0.0 } },
    };
    Params { surface, lambdas, under }
}

/// The samples of one stage of the fit and, for a layered model, the interface-albedo rule it uses.
struct Stage<'a> {
    data: &'a Data,
    quadrature: Option<&'a Quadrature>,
    weighting: Weighting,
}

impl<'a> Stage<'a> {
    fn problem(&self, tables: &'a GeneralTables, coords: &Coordinates, from: &Params) -> Problem<'a> {
        Problem::new(tables, self.data, self.quadrature, coords.clone(), from)
    }

    /// The final stage on this stage's samples (`finish`), as a candidate.
    fn finish(&self, tables: &'a GeneralTables, coords: &Coordinates, from: (Descended<Params>, Params)) -> Candidate {
        let done = finish(from, |s| self.problem(tables, coords, s));
        Candidate {
            at_ends: coords.at_ends(&done.params),
            params: done.params,
            diffraction: coords.diffraction(),
            weighting: self.weighting,
            samples: self.data.len(),
            loss: done.loss,
            evaluations: done.evaluations,
            termination: done.termination,
        }
    }
}

/// Fits `options.model` to `measured`; `log` receives one line per stage. Two passes, each a fit of its own
/// from the same starts: on the subsamples of the loss (`Weighting::Shared`) and on those drawn by the
/// measure alone (`Weighting::Measure`, docs/fit.md "The method"). `best` is the first pass's kept candidate
/// (`kept_in`); a caller that renders the candidates chooses between the passes (`kept_by_render`).
pub fn fit(tables: &GeneralTables, samples: &Samples, options: &FitOptions, log: impl Fn(&str) + Sync) -> Fit {
    let mut domain = tables.domain();
    domain.b_over_lambda =
        (domain.b_over_lambda.0.max(options.b_over_lambda.0), domain.b_over_lambda.1.min(options.b_over_lambda.1));
    domain.u_max = domain.u_max.min(options.b_over_lambda.1);
    let layered = options.model != Model::Conductor;
    let rules = layered.then(|| (Quadrature::scout(), Quadrature::fit()));
    // The passes side by side: each is deterministic on its own, and together they keep both cores busy
    // through LM's serial steps.
    let measure_log = |line: &str| log(&format!("by measure: {line}"));
    let (shared, by_measure) = rayon::join(
        || run_pass(tables, &domain, stages(&samples.shared, rules.as_ref(), Weighting::Shared), options, &log),
        || {
            run_pass(
                tables,
                &domain,
                stages(&samples.by_measure, rules.as_ref(), Weighting::Measure),
                options,
                &measure_log,
            )
        },
    );
    let candidates: Vec<Candidate> = shared.into_iter().chain(by_measure).collect();
    let best = candidates
        [kept_in(&candidates, Weighting::Shared).expect("the fit without diffraction is always finished")]
    .clone();
    Fit { model: options.model, best, candidates, fit_samples: samples.shared.fit.len(), domain }
}

/// A pass's scout and fit stages, a layered model's with their interface-albedo rules.
fn stages<'a>(
    pass: &'a Pass,
    rules: Option<&'a (Quadrature, Quadrature)>,
    weighting: Weighting,
) -> (Stage<'a>, Stage<'a>) {
    (
        Stage { data: &pass.scout, quadrature: rules.map(|r| &r.0), weighting },
        Stage { data: &pass.fit, quadrature: rules.map(|r| &r.1), weighting },
    )
}

/// One pass of the fit: without diffraction, then with it where it fits better; its candidates.
fn run_pass(
    tables: &GeneralTables,
    domain: &Domain,
    (scout_set, fit_set): (Stage, Stage),
    options: &FitOptions,
    log: &(dyn Fn(&str) + Sync),
) -> Vec<Candidate> {
    let mut candidates: Vec<Candidate> = Vec::new();
    let mut plain_scout = f64::NAN;
    for diffraction in [false, true] {
        let coords = Coordinates::new(domain, options.lambdas, options.model, diffraction);
        // Without diffraction: a grid of EPDs. With it: the EPD and what lies under, fitted without
        // it, under a grid of nano-geometries. The best starts are refined on the scout subsample,
        // the best of them finished on the fit subsample.
        let families: Vec<Vec<Params>> = match candidates.first() {
            None => vec![[0.01, 0.03, 0.1, 0.3]
                .iter()
                .flat_map(|&beta| [0.4, 1.0, 2.0].map(|p| start(options.model, options.lambdas, beta, p)))
                .collect()],
            Some(plain) => {
                // c at 2 only: c in {1.5, 2.5} as well found the same fits on the shared measured files
                // (docs/fit.md "The loss") at up to 1.4 times the time. A conductor's in two families, each
                // with its best start refined: its index as fitted without diffraction, and a fresh start's.
                // Fitted without diffraction, it can take a dielectric-like index (k at 0, the same F0) that
                // its diffracting fit does not leave (synthetic broad and narrow: 20 % from the target, 1e-4
                // from the fresh index). A layered model's index has no such trap; its second family made the
                // first four shared MERL files 1.2-2 times slower (one run, beside a change of subsample).
                let fresh = start(options.model, options.lambdas, plain.params.surface.beta, plain.params.surface.p);
                let unders = match options.model {
                    Model::Conductor => vec![plain.params.under, fresh.under],
                    _ => vec![plain.params.under],
                };
                unders
                    .iter()
                    .map(|&under| {
                        let mut starts = Vec::new();
                        for sigma_s in [0.005, 0.02, 0.08] {
                            for b in [0.3, 1.0, 3.0, 10.0] {
                                let surface = Surface { sigma_s, b, c: 2.0, ..plain.params.surface };
                                starts.push(Params { surface, under, ..plain.params });
                            }
                        }
                        starts
                    })
                    .collect()
            }
        };
        let with = if diffraction { "with" } else { "without" };
        let scouted = families
            .into_iter()
            .map(|starts| scout(starts, |s| scout_set.problem(tables, &coords, s), options.refined_starts))
            .min_by(|a, b| a.0.loss.total_cmp(&b.0.loss))
            .expect("a family of starts");
        let refined = &scouted.0;
        log(&format!("{with} diffraction: scout fit on {} samples, loss {:.4e}", scout_set.data.len(), refined.loss));
        // Diffraction is finished on the fit subsample only where it already fits better on the
        // scout's, by `richer_fits_better`'s rule after the scout's shorter refinement: a heuristic
        // (the result must pass the rule on the fit subsample), measured on the files outside the
        // family, where the skipped final stages cost up to 59 s and would have been dropped.
        let scout_residuals = (3 * scout_set.data.len()) as f64;
        if !diffraction {
            plain_scout = refined.loss;
        } else if !richer_fits_better(plain_scout / scout_residuals, refined.loss / scout_residuals) {
            log("with diffraction: no better on the scout subsample, not finished");
            break;
        } else if let Some(rival) = options.rival.filter(|&r| refined.loss / scout_residuals > RIVAL * r) {
            // On a strongly diffracting metal (b 12) a plastic's diffracting stage took 18 s, 10^5 times
            // above the conductor's loss.
            log(&format!(
                "with diffraction: mean squared residual {:.3e} on the scout subsample, over {RIVAL} times another model's {rival:.3e}: not finished",
                refined.loss / scout_residuals
            ));
            break;
        }
        let done = fit_set.finish(tables, &coords, scouted);
        log(&format!(
            "{with} diffraction: fit on {} samples, loss {:.4e} ({}, {} evaluations)",
            fit_set.data.len(),
            done.loss,
            done.termination,
            done.evaluations
        ));
        if !done.at_ends.is_empty() {
            let list: Vec<String> = done.at_ends.iter().map(|a| a.to_string()).collect();
            log(&format!("{with} diffraction: at the end of their range: {}", list.join(", ")));
            if diffraction && done.at_ends.iter().any(|a| a.name == "b" || a.name == "c") {
                let hint = if options.model == Model::Conductor { ": `--model plastic` may fit better" } else { "" };
                log(&format!(
                    "the diffraction term's b or c at a bound usually stands in for a diffuse or constant term{hint}"
                ));
            }
            if done.at_ends.iter().any(|a| a.name == "ior" && a.side == "upper") {
                // F0 = ((n - 1) / (n + 1))^2 at normal incidence
                let f0 = ((IOR.1 - 1.0) / (IOR.1 + 1.0)).powi(2);
                log(&format!(
                    "ior at its upper end: the coat reflects more than a dielectric's (F0 {f0:.2} at {}): `--model conductor` may fit better",
                    IOR.1
                ));
            }
        }
        candidates.push(done);
    }
    candidates
}

/// Whether a model with more parameters fits better than a simpler one, from their mean squared
/// residuals: by more than 1 % and by more than 1e-6 (a residual of 1e-3: below that both fit to
/// rounding and the quadratures' noise). Used for diffraction, and for `--model auto`'s choice.
pub fn richer_fits_better(simpler: f64, richer: f64) -> bool {
    let gain = simpler - richer;
    gain > 0.01 * simpler && gain > 1e-6
}

/// Whether a model with more parameters renders better than a simpler one, from their renders' SMAPE
/// (`render`): by more than 1 % of it and by more than 0.005 (half a per cent of every pixel: below
/// that, on a file both fit to rounding, the quadratures' noise decides).
pub fn richer_renders_better(simpler: f64, richer: f64) -> bool {
    let gain = simpler - richer;
    gain > 0.01 * simpler && gain > 0.005
}

/// A pass's kept candidate among `candidates`: with diffraction where it lowers the loss by `richer_fits_better`
/// (it adds three parameters), without it otherwise; None where the pass was not run.
pub fn kept_in(candidates: &[Candidate], weighting: Weighting) -> Option<usize> {
    let of =
        |diffraction: bool| candidates.iter().position(|c| c.weighting == weighting && c.diffraction == diffraction);
    let plain = of(false)?;
    let residuals = (3 * candidates[plain].samples) as f64;
    Some(match of(true) {
        Some(d) if richer_fits_better(candidates[plain].loss / residuals, candidates[d].loss / residuals) => d,
        _ => plain,
    })
}

/// The candidate a render keeps, from each candidate's render SMAPE (`smape`, in `candidates`' order): the
/// first pass's kept candidate (`Fit::best`, with or without diffraction by its loss), or the by-measure pass's
/// (the same rule on its own loss) where it renders better by `richer_renders_better`'s margin. On a file the
/// model fits to the tables' rounding both passes render alike, and the first holds the specular peak: kept
/// for any lower SMAPE, the second pass's candidates brought synthetic materials back up to 100 times further
/// from their targets (docs/fit.md "The method").
pub fn kept_by_render(fit: &Fit, smape: &[f64]) -> usize {
    let shared = kept_in(&fit.candidates, Weighting::Shared)
        .expect("the first pass's fit without diffraction is always finished");
    match kept_in(&fit.candidates, Weighting::Measure) {
        Some(m) if richer_renders_better(smape[shared], smape[m]) => m,
        _ => shared,
    }
}

/// rho per channel of a candidate at every direction pair of `data`, a layered model's interface albedo by
/// a rule five times the fit's (24 x 200 x 24: E_F within 4.7e-4 of the per-material tables, against the
/// fit rule's 8e-4): what a renderer of the built material sees (examples/fit/compare.py renders it through
/// the C BRDF: a plastic on ilm_l3_37_matte within 0.4 % of SMAPE, 1.7 % with the fit's rule).
pub fn candidate_rho(tables: &GeneralTables, data: &Data, domain: &Domain, candidate: &Candidate) -> Vec<[f64; 3]> {
    let model = model_of(&candidate.params);
    let quadrature = (model != Model::Conductor).then(Quadrature::render);
    let coords = Coordinates::new(domain, candidate.params.lambdas, model, candidate.diffraction);
    let problem = Problem::new(tables, data, quadrature.as_ref(), coords, &candidate.params);
    let (params, state) = (&problem.params, problem.state());
    (0..data.len()).into_par_iter().map(|n| [0, 1, 2].map(|ch| rho(params, state, &data.geometry[n], n, ch))).collect()
}

/// A BRDF given as a function of (wi, wo), isotropic, against every measured sample of `samples`.
pub fn agreement_of(samples: &Samples, rho: impl Fn([f64; 3], [f64; 3]) -> [f64; 3] + Sync) -> Agreement {
    let all = samples.all();
    let values: Vec<[f64; 3]> = all
        .geometry
        .par_iter()
        .map(|g| {
            let (wi, wo) = g.directions();
            rho(wi, wo)
        })
        .collect();
    agreement(all, |n, ch| values[n][ch])
}

/// A model, `rho(n, ch)` at sample n and channel ch of `data`, against the measured samples.
pub(crate) fn agreement(data: &Data, rho: impl Fn(usize, usize) -> f64 + Sync) -> Agreement {
    let sums: Vec<[f64; 8]> = (0..data.len())
        .into_par_iter()
        .map(|n| {
            let g = &data.geometry[n];
            let mut out = [0.0; 8];
            for ch in 0..3 {
                let (f, t) = (g.cos_i * rho(n, ch), data.value[3 * n + ch]);
                out[ch] += (f - t) * (f - t);
                out[3 + ch] += t * t;
                // the log metric of values clamped at 0: an RGL file's out-of-gamut colours are below 0
                // (chm_mint), where ln(1 + x) has no value
                let (f, t) = (f.max(0.0), t.max(0.0));
                out[6] += (f.ln_1p() - t.ln_1p()).powi(2);
                out[7] += t.ln_1p().powi(2);
            }
            out
        })
        .collect();
    let total = sums.iter().fold([0.0; 8], |mut a, s| {
        for (x, y) in a.iter_mut().zip(s) {
            *x += y;
        }
        a
    });
    let residuals = (3 * data.len()) as f64;
    Agreement {
        relative_rms: ((total[0] + total[1] + total[2]) / (total[3] + total[4] + total[5])).sqrt(),
        relative_rms_per_channel: [0, 1, 2].map(|ch| (total[ch] / total[3 + ch]).sqrt()),
        log_rms: (total[6] / residuals).sqrt(),
        log_rms_of_zero: (total[7] / residuals).sqrt(),
        samples: data.len(),
    }
}

impl Fit {
    /// The candidate kept against every measured sample of `samples` (its error, whatever the loss), a
    /// layered model's interface albedo on the render's quadrature (`Quadrature::render`, finer than the fit's).
    pub fn agreement(&self, tables: &GeneralTables, samples: &Samples) -> Agreement {
        let all = samples.all();
        let rho = candidate_rho(tables, all, &self.domain, &self.best);
        agreement(all, |n, ch| rho[n][ch])
    }

    /// The mean squared residual of the candidate kept, on its pass's fit subsample: a rival's for
    /// `FitOptions::rival`.
    pub fn mean_squared_residual(&self) -> f64 {
        self.best.loss / (3 * self.best.samples) as f64
    }
}

fn model_of(p: &Params) -> Model {
    match p.under {
        Under::Conductor { .. } => Model::Conductor,
        Under::Layered { beneath: Beneath::Diffuse { .. }, .. } => Model::Plastic,
        Under::Layered { beneath: Beneath::Medium { .. }, .. } => Model::Subsurface,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(diffraction: bool, weighting: Weighting) -> Candidate {
        let surface = Surface { beta: 0.1, p: 1.0, sigma_s: 0.0, b: 1.0, c: 2.0 };
        let under = Under::Conductor { eta: [1.5; 3], k: [3.0; 3] };
        Candidate {
            params: Params { surface, lambdas: [0.65, 0.55, 0.45], under },
            diffraction,
            weighting,
            samples: 10_000,
            loss: 1.0,
            evaluations: 1,
            termination: String::new(),
            at_ends: vec![],
        }
    }

    /// In each pass the candidate its loss keeps; the first pass's, or the second's where it renders better by
    /// more than 1 % and 0.005.
    #[test]
    fn the_render_takes_the_second_pass_only_where_it_renders_better_by_a_margin() {
        use Weighting::{Measure, Shared};
        let with_loss = |c: Candidate, loss: f64| Candidate { loss, ..c };
        let four = vec![
            with_loss(candidate(false, Shared), 2.0),
            with_loss(candidate(true, Shared), 1.0),
            with_loss(candidate(false, Measure), 1.0),
            with_loss(candidate(true, Measure), 0.995),
        ];
        let fit = |candidates: Vec<Candidate>| Fit {
            model: Model::Conductor,
            best: candidates[0].clone(),
            candidates,
            fit_samples: 10_000,
            domain: Domain {
                beta: (0.005, 0.5),
                p: (0.2, 5.0),
                c: (1.02, 3.02),
                b_over_lambda: (0.1, 30.0),
                u_max: 30.0,
            },
        };
        let f = fit(four);
        // by the loss: diffraction in the first pass (half the loss), not in the second (0.5 % lower)
        assert_eq!((kept_in(&f.candidates, Shared), kept_in(&f.candidates, Measure)), (Some(1), Some(2)));
        assert_eq!(kept_by_render(&f, &[0.10, 0.09, 0.08, 0.01]), 2, "the second pass's kept candidate, 0.01 better");
        assert_eq!(kept_by_render(&f, &[0.10, 0.09, 0.087, 0.01]), 1, "0.003 better: the first pass's");
        assert_eq!(kept_by_render(&f, &[0.0012, 0.0011, 0.0009, 0.0009]), 1, "a fit to rounding keeps the first pass");
        let plain_only = fit(vec![candidate(false, Shared), candidate(false, Measure)]);
        assert_eq!(kept_by_render(&plain_only, &[0.2, 0.1]), 1);
    }
}
