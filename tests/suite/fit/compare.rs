//! The comparison models of `twoscale fit --compare` (pipeline/fit/src/compare) are what they say:
//! each closed form against values by an independent implementation, and each model's fit recovering
//! a MERL file written by the model itself.

use crate::common;

use common::shared_tables::shared_tables;
use serde_json::Value;
use std::collections::BTreeMap;
use twoscale_fit::compare::{fit_comparison, Comparison, Values};
use twoscale_fit::fit::Samples;
use twoscale_fit::loss::Loss;
use twoscale_fit::measured;
use twoscale_fit::merl::{self, DIMS, MIN_COS, SCALES};
use twoscale_fit::model::GeneralTables;
use twoscale_fit::published::PublishedFits;

/// The largest relative difference of `got` from `want` over every channel and pair, with where it is;
/// each within 1e-9 relative (an exact 0 must be an exact 0).
fn compare(what: &str, want: &[[f64; 3]], got: impl Fn(usize) -> [f64; 3]) -> f64 {
    let mut worst = 0.0f64;
    for (n, want) in want.iter().enumerate() {
        let got = got(n);
        for ch in 0..3 {
            let (diff, scale) = ((got[ch] - want[ch]).abs(), want[ch].abs().max(1e-300));
            assert!(diff <= 1e-9 * scale, "{what}, direction pair {n}, channel {ch}: {} against {}", got[ch], want[ch]);
            worst = worst.max(diff / scale);
        }
    }
    worst
}

fn triple(v: &Value) -> [f64; 3] {
    serde_json::from_value(v.clone()).unwrap()
}

/// abc and sgd, as `--compare` evaluates them (`Values`, the fitted parameters' form) at every published
/// fit of the 100 MERL materials (the SGD's held parameters at the published values), against
/// shared/data/published-fits/golden.json (an independent evaluation, 10 significant digits): within
/// 1e-9 relative.
#[test]
fn abc_and_sgd_match_the_published_fits_reference_values() {
    let dir = common::shared_data().join("published-fits");
    let golden: Value = serde_json::from_slice(&std::fs::read(dir.join("golden.json")).unwrap()).unwrap();
    let directions: Vec<[[f64; 3]; 2]> = serde_json::from_value(golden["directions"].clone()).unwrap();
    let fits = PublishedFits::carried();
    let lambdas = [0.65, 0.55, 0.45];
    for model in [Comparison::Abc, Comparison::Sgd] {
        let values: BTreeMap<String, Vec<[f64; 3]>> = serde_json::from_value(golden[model.name()].clone()).unwrap();
        assert_eq!(values.len(), 100);
        let mut worst = 0.0f64;
        for (material, want) in &values {
            let found = fits.find(material).unwrap();
            let v = match model {
                Comparison::Abc => {
                    let a = found.abc.unwrap();
                    [&a.kd[..], &a.a, &[a.b, a.c, a.ior]].concat()
                }
                _ => {
                    let s = found.sgd.unwrap();
                    [s.rho_d, s.rho_s, s.alpha, s.p, s.f0, s.f1, s.kap, s.lambda, s.c, s.k, s.theta0].concat()
                }
            };
            let fitted = Values::new(model, lambdas, &v);
            let what = format!("{}, {material}", model.name());
            worst = worst.max(compare(&what, want, |n| fitted.rho(directions[n][0], directions[n][1])));
        }
        println!(
            "{}: 100 materials x {} pairs, largest relative difference {worst:.2e}",
            model.name(),
            directions.len()
        );
    }
}

/// low_smooth and he against pipeline/fit/golden/bbm.json: bsdfbenchmark/bbm's `lowsmooth` and
/// `heholzschuch` (plus a Lambertian term) compiled and run by pipeline/fit/golden/bbm_golden.sh, three
/// parameter sets each at 64 direction pairs, within 1e-9 relative.
#[test]
fn low_smooth_and_he_match_the_reference_implementation() {
    let path = common::repo_root().join("pipeline/fit/golden/bbm.json");
    let golden: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let directions: Vec<[[f64; 3]; 2]> = serde_json::from_value(golden["directions"].clone()).unwrap();
    let lambdas = triple(&golden["wavelengths"]);
    assert!(directions.len() >= 50);
    for model in [Comparison::LowSmooth, Comparison::He] {
        let sets = golden[model.name()].as_array().unwrap();
        assert_eq!(sets.len(), 3);
        let mut worst = 0.0f64;
        for (s, set) in sets.iter().enumerate() {
            let v: Vec<f64> = match model {
                Comparison::LowSmooth => {
                    let scalar = |k: &str| set[k].as_f64().unwrap();
                    [&triple(&set["kd"])[..], &triple(&set["A"]), &[scalar("B"), scalar("C"), scalar("eta")]].concat()
                }
                _ => [
                    &[set["sigma"].as_f64().unwrap(), set["tau"].as_f64().unwrap()][..],
                    &triple(&set["eta"]),
                    &triple(&set["k"]),
                    &triple(&set["kd"]),
                ]
                .concat(),
            };
            let want: Vec<[f64; 3]> = serde_json::from_value(set["rho"].clone()).unwrap();
            assert_eq!(want.len(), directions.len());
            let fitted = Values::new(model, lambdas, &v);
            let what = format!("{}, set {s}", model.name());
            worst = worst.max(compare(&what, &want, |n| fitted.rho(directions[n][0], directions[n][1])));
        }
        println!("{}: 3 sets x {} pairs, largest relative difference {worst:.2e}", model.name(), directions.len());
    }
}

/// A MERL file of `values` (rho at each bin's centre; below the horizon marked).
fn merl_file(values: &Values) -> Vec<u8> {
    let n = DIMS[0] * DIMS[1] * DIMS[2];
    let rho: Vec<[f64; 3]> = (0..n)
        .map(|b| {
            let (i, j, k) = (b / (DIMS[1] * DIMS[2]), (b / DIMS[2]) % DIMS[1], b % DIMS[2]);
            let d = merl::directions(i, j, k);
            if d.wi[2] <= MIN_COS || d.wo[2] <= MIN_COS {
                [-1.0; 3]
            } else {
                values.rho(d.wi, d.wo)
            }
        })
        .collect();
    let stored = |ch: usize, n: usize| if rho[n][ch] < 0.0 { -1.0 } else { rho[n][ch] / SCALES[ch] };
    super::merl(DIMS.map(|d| d as i32), stored, n)
}

/// Each closed-form comparison model fitted to a MERL file it wrote itself (a glossy material of each,
/// away from its parameters' ranges' ends), with `twoscale fit`'s samples and loss: relative RMS of
/// rho cos theta_i over every valid sample at most 1e-3.
#[test]
fn each_comparison_model_recovers_its_own_file() {
    let tables = GeneralTables::open(&shared_tables().join("default")).unwrap();
    let lambdas = [0.65, 0.55, 0.45];
    let materials = [
        (Comparison::LowSmooth, vec![0.05, 0.1, 0.2, 40.0, 30.0, 20.0, 200.0, 1.3, 1.6]),
        (Comparison::Abc, vec![0.05, 0.1, 0.2, 30.0, 25.0, 20.0, 3000.0, 1.1, 1.7]),
        (
            Comparison::Sgd,
            [[0.1, 0.05, 0.02], [0.4, 0.5, 0.6], [0.02, 0.03, 0.04], [0.5, 0.6, 0.7], [0.2, 0.3, 0.4], [0.1, 0.2, 0.3]]
                .iter()
                .chain(&[[1.0; 3], [0.0; 3], [0.0; 3], [1.0; 3], [0.0; 3]])
                .flatten()
                .copied()
                .collect(),
        ),
        (Comparison::He, vec![0.07, 2.0, 0.3, 0.5, 1.2, 3.0, 2.5, 2.0, 0.05, 0.1, 0.2]),
    ];
    for (model, v) in materials {
        let truth = Values::new(model, lambdas, &v);
        let file = measured::parse(&merl_file(&truth)).unwrap();
        let samples = Samples::new(&file, &Loss::FIT, Some(10_000));
        let clock = std::time::Instant::now();
        let fitted = fit_comparison(&tables, &samples, model, lambdas, |_| {});
        let err = fitted.agreement.relative_rms;
        println!(
            "{}: relative RMS {err:.2e} ({}, {} evaluations, {:.1} s): {:?}",
            model.name(),
            fitted.termination,
            fitted.evaluations,
            clock.elapsed().as_secs_f64(),
            fitted.params.named()
        );
        assert!(err <= 1e-3, "{} does not recover its own file: relative RMS {err}", model.name());
    }
}
