//! Stress cases at and beyond every domain edge: the invariants docs/maths.md states
//! (finite, in range, monotone, continuous, exact ends), evaluated directly.

use rayon::prelude::*;
use serde_json::{json, Value};
use twoscale_generate::tables::epd_albedo_column::albedo_column;
use twoscale_generate::tables::epd_math::g1;
use twoscale_generate::tables::kcorr_math::renorm;
use twoscale_generate::tables::lambda_table::LambdaTable;
use twoscale_generate::tables::zh_math::{d_lobe, s_lobe};

/// One failed check.
#[derive(Clone, Debug)]
pub struct Failure {
    pub check: &'static str,
    pub at: Value,
    pub detail: String,
}

/// Logarithmically spaced values from `lo` to `hi`.
fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| (lo.ln() + (hi.ln() - lo.ln()) * i as f64 / (n - 1) as f64).exp()).collect()
}

/// G1 along a from 0 through 1e-30..1e30 to +inf, for p in [0.01, 100]: finite,
/// in [0, 1], 1 at 0, 0 at inf, non-increasing, continuous (a relative step
/// of 1e-9 moves G1 by less than 1e-6).
fn epd_cases(n_p: usize, n_a: usize) -> (usize, Vec<Failure>) {
    let ps = logspace(0.01, 100.0, n_p);
    let mut a_values = vec![0.0];
    a_values.extend(logspace(1e-30, 1e30, n_a));
    a_values.push(f64::INFINITY);
    let results: Vec<(usize, Vec<Failure>)> = ps
        .par_iter()
        .map(|&p| {
            let mut fails = Vec::new();
            let mut prev = f64::INFINITY;
            for &a in &a_values {
                let g = g1(p, a);
                let at = json!({ "p": p, "a": twoscale_generate::accuracy::json_f64(a) });
                if !(g.is_finite() && (0.0..=1.0).contains(&g)) {
                    fails.push(Failure { check: "epd_g1 finite in [0, 1]", at: at.clone(), detail: format!("{g}") });
                }
                if (a == 0.0 && g != 1.0) || (a.is_infinite() && g != 0.0) {
                    fails.push(Failure { check: "epd_g1 exact ends", at: at.clone(), detail: format!("{g}") });
                }
                if g > prev * (1.0 + 1e-12) {
                    fails.push(Failure {
                        check: "epd_g1 non-increasing in a",
                        at: at.clone(),
                        detail: format!("{prev} -> {g}"),
                    });
                }
                if a > 0.0 && a.is_finite() {
                    let near = g1(p, a * (1.0 + 1e-9));
                    if (near - g).abs() > 1e-6 {
                        fails.push(Failure { check: "epd_g1 continuous in a", at, detail: format!("{g} vs {near}") });
                    }
                }
                prev = g;
            }
            (a_values.len() * 2, fails)
        })
        .collect();
    results.into_iter().fold((0, Vec::new()), |(n, mut f), (m, g)| {
        f.extend(g);
        (n + m, f)
    })
}

/// R over s in {0, 1e-15, ..., 1 - 1e-15, 1}, B in [1e-6, 1e8], c in [1 + 1e-9, 1e4]:
/// finite, in [0, 1], non-increasing in s, non-decreasing in B, continuous at the s ends.
fn kcorr_cases(n_b: usize, n_c: usize) -> (usize, Vec<Failure>) {
    let ss = [0.0, 1e-15, 1e-6, 0.3, 0.7, 0.99, 1.0 - 1e-9, 1.0 - 1e-15, 1.0];
    let bs = logspace(1e-6, 1e8, n_b);
    let mut cs = vec![1.0 + 1e-9];
    cs.extend(logspace(1.01, 1e4, n_c - 1));
    let results: Vec<(usize, Vec<Failure>)> = cs
        .par_iter()
        .map(|&c| {
            let mut fails = Vec::new();
            let mut count = 0;
            let table: Vec<Vec<f64>> = bs.iter().map(|&b| ss.iter().map(|&s| renorm(s, b, c)).collect()).collect();
            for (ib, row) in table.iter().enumerate() {
                for (is, &r) in row.iter().enumerate() {
                    count += 1;
                    let at = json!({ "s": ss[is], "b_over_lambda": bs[ib], "c": c });
                    if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
                        fails.push(Failure {
                            check: "kcorr_renorm finite in [0, 1]",
                            at: at.clone(),
                            detail: format!("{r}"),
                        });
                    }
                    if is > 0 && r > row[is - 1] * (1.0 + 1e-10) + 1e-300 {
                        fails.push(Failure {
                            check: "kcorr_renorm non-increasing in s",
                            at: at.clone(),
                            detail: format!("{} -> {r}", row[is - 1]),
                        });
                    }
                    if ib > 0 && r < table[ib - 1][is] * (1.0 - 1e-10) {
                        fails.push(Failure {
                            check: "kcorr_renorm non-decreasing in B",
                            at,
                            detail: format!("{} -> {r}", table[ib - 1][is]),
                        });
                    }
                }
                // Continuity at both ends of s (neighbours 1e-15 apart): R varies on
                // the PSD's width ~ 1/(B sqrt(c)) near s = 1, so allow a step of
                // 10 * 1e-15 * B sqrt(c) there (a jump between branches would exceed it).
                for (i, j) in [(0, 1), (ss.len() - 1, ss.len() - 2)] {
                    count += 1;
                    let allowed = 1e-6 * row[i].max(row[j]) + 10.0 * 1e-15 * bs[ib] * c.sqrt();
                    if (row[i] - row[j]).abs() > allowed + 1e-300 {
                        fails.push(Failure {
                            check: "kcorr_renorm continuous at the s ends",
                            at: json!({ "s": ss[i], "b_over_lambda": bs[ib], "c": c }),
                            detail: format!("{} vs {}", row[i], row[j]),
                        });
                    }
                }
            }
            (count, fails)
        })
        .collect();
    results.into_iter().fold((0, Vec::new()), |(n, mut f), (m, g)| {
        f.extend(g);
        (n + m, f)
    })
}

/// The two lobes of the convolution over u in [0, 1e4], beta in [1e-5, 2],
/// p in [0.01, 100], c in [1 + 1e-9, 1e4], at angles from 0 to 90 degrees:
/// finite and non-negative, and non-increasing in the angle.
fn lobe_cases(n: usize) -> (usize, Vec<Failure>) {
    let mut us = vec![0.0];
    us.extend(logspace(1e-6, 1e4, n - 1));
    let betas = logspace(1e-5, 2.0, n);
    let ps = logspace(0.01, 100.0, n);
    let cs = [1.0 + 1e-9, 2.0, 1e4];
    let thetas: Vec<f64> = (0..=16).map(|k| std::f64::consts::FRAC_PI_2 * k as f64 / 16.0).collect();
    let trig: Vec<(f64, f64)> = thetas.iter().map(|t| (t.sin().powi(2), t.cos().powi(2))).collect();
    let mut fails = Vec::new();
    let mut count = 0;
    let mut check = |name: &'static str, at: Value, values: Vec<f64>| {
        count += values.len();
        for (k, v) in values.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                let angle = thetas.get(k).map_or("(monotonicity)".to_string(), |t| format!("theta = {t}"));
                fails.push(Failure { check: name, at: at.clone(), detail: format!("{v} at {angle}") });
            }
        }
    };
    for &u in &us {
        for &c in &cs {
            let v: Vec<f64> = trig.iter().map(|&(s2, c2)| s_lobe(s2, c2, u, c)).collect();
            let decreasing = v.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-12));
            let mut checked = v.clone();
            if !decreasing {
                checked.push(f64::NAN); // reported below as a failure of the same lobe
            }
            check("diffraction lobe S finite, >= 0 and non-increasing in theta", json!({ "u": u, "c": c }), checked);
        }
    }
    for &beta in &betas {
        for &p in &ps {
            let v: Vec<f64> = trig.iter().map(|&(s2, c2)| d_lobe(s2, c2, p, beta)).collect();
            check("NDF lobe D finite, >= 0", json!({ "beta": beta, "p": p }), v);
        }
    }
    (count, fails)
}

/// zh_lobe: the derived angle over u in [0, 1e4], beta in [1e-5, 2], p in
/// [0.01, 100] (finite, from 0 at theta = 0 to 1 at pi/2, increasing, inverted
/// to 1e-12), the control-variate terms there (finite, the weights in [0, 1] and
/// summing to 1), and the convolution C_L at the corners of the table's domain at
/// the 1000 angles of docs/maths.md section 4 (finite, and not below -1e-6 of its maximum, the
/// series' truncation level; the table stores max(C, 1e-7 max)).
fn convolved_cases(n: usize) -> (usize, Vec<Failure>) {
    use twoscale_generate::tables::zh_lobe::{reference, DERIVATION};
    use twoscale_generate::tables::zh_math::ThetaRule;
    use twoscale_tables::lobe::{terms, weights, LobeParams};
    let mut fails = Vec::new();
    let mut count = 0;
    let thetas: Vec<f64> = (0..=64).map(|k| std::f64::consts::FRAC_PI_2 * k as f64 / 64.0).collect();
    let mut us = vec![0.0];
    us.extend(logspace(1e-6, 1e4, n - 1));
    for &u in &us {
        for &beta in &logspace(1e-5, 2.0, n) {
            for &p in &logspace(0.01, 100.0, n) {
                let v: Vec<f64> = thetas.iter().map(|&t| DERIVATION.forward(t, &[u, p, beta])).collect();
                count += v.len();
                let at = json!({ "u": u, "beta": beta, "p": p });
                let ends = v[0] == 0.0 && (v[v.len() - 1] - 1.0).abs() <= 1e-12;
                let increasing = v.windows(2).all(|w| w[1] > w[0]);
                let inverse = thetas
                    .iter()
                    .zip(&v)
                    .all(|(&t, &x)| (DERIVATION.inverse(x, &[u, p, beta]) - t).abs() <= 1e-12 * t.max(1e-3));
                if !(v.iter().all(|x| x.is_finite()) && ends && increasing && inverse) {
                    fails.push(Failure {
                        check: "zh_lobe derived angle: finite, 0..1, increasing, invertible",
                        at: at.clone(),
                        detail: format!("{v:?}"),
                    });
                }
                // The control variates' weights and terms at every angle.
                let weights: Vec<[f64; 4]> = v.iter().map(|&x| weights(u, p, beta, x)).collect();
                let unit = weights
                    .iter()
                    .all(|a| a.iter().all(|x| (0.0..=1.0).contains(x)) && (a.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                for c in [1.02, 3.02] {
                    let terms: Vec<[f64; 4]> =
                        thetas.iter().map(|&theta| terms(theta, &LobeParams { u, c, p, beta }, [true; 4])).collect();
                    count += terms.len();
                    if !(unit && terms.iter().flatten().all(|x| x.is_finite())) {
                        fails.push(Failure {
                            check: "zh_lobe control variates: finite terms, weights in [0, 1] summing to 1",
                            at: at.clone(),
                            detail: format!("c {c}, {weights:?}, {terms:?}"),
                        });
                    }
                }
            }
        }
    }
    let corners: Vec<Vec<f64>> = (0..16)
        .map(|k: usize| {
            vec![[0.0, 100.0][k & 1], [1.02, 3.02][k >> 1 & 1], [0.2, 5.0][k >> 2 & 1], [0.005, 0.5][k >> 3 & 1]]
        })
        .collect();
    let degree = twoscale_generate::tables::zh_grid::DEFAULT_DEGREE;
    let c = reference(&corners, &ThetaRule::standard(degree), degree);
    for (pt, row) in corners.iter().zip(c.rows()) {
        count += row.len();
        let max = row.iter().fold(0.0f64, |m, x| m.max(*x));
        if let Some((k, x)) = row.iter().enumerate().find(|(_, x)| !(x.is_finite() && **x >= -1e-6 * max)) {
            let at = json!({ "u": pt[0], "c": pt[1], "p": pt[2], "beta": pt[3] });
            fails.push(Failure {
                check: "zh_lobe C finite and >= -1e-6 max",
                at,
                detail: format!("{x} at sample {k}, max {max}"),
            });
        }
    }
    (count, fails)
}

/// epd_albedo's E over p in [0.02, 20] and beta in [1e-3, 1] (beyond the table's [0.05, 5] x
/// [0.005, 0.5]), at theta_i = 0 and tan theta_i from 1e-12 to 1e6 (the table's end, mu = 1e-6):
/// finite, in [0, 1 + 1e-6] (E <= 1: G2 <= G1(i), and D G1(i) (i.h)/cos theta_i integrates to 1),
/// continuous (a relative step of 1e-9 in tan theta_i moves E by less than 1e-6); beyond the end
/// (tan theta_i up to 1e12, and pi/2), where a runtime clamps, finite and in [0, 1 + 1e-3].
fn albedo_cases(n_p: usize, n_beta: usize, n_theta: usize) -> (usize, Vec<Failure>) {
    let inside: Vec<f64> =
        std::iter::once(0.0).chain(logspace(1e-12, 1e6, n_theta).into_iter().map(f64::atan)).collect();
    let beyond: Vec<f64> =
        logspace(1e7, 1e12, 4).into_iter().map(f64::atan).chain([std::f64::consts::FRAC_PI_2]).collect();
    let results: Vec<(usize, Vec<Failure>)> = logspace(0.02, 20.0, n_p)
        .par_iter()
        .map(|&p| {
            let table = LambdaTable::new(p);
            let mut fails = Vec::new();
            // Each column holds the inside points, the points beyond, then each inside point moved by 1e-9.
            let near: Vec<f64> = inside.iter().map(|t| (t.tan() * (1.0 + 1e-9)).atan()).collect();
            let thetas: Vec<f64> = [&inside[..], &beyond[..], &near[..]].concat();
            for &beta in &logspace(1e-3, 1.0, n_beta) {
                let column = albedo_column(&table, beta, &thetas);
                let (values, near) = column.split_at(inside.len() + beyond.len());
                for (k, (&theta, &e)) in thetas.iter().zip(values).enumerate() {
                    let end = k >= inside.len();
                    let at = json!({ "p": p, "beta": beta, "theta_i": theta });
                    let top = if end { 1.0 + 1e-3 } else { 1.0 + 1e-6 };
                    if !(e.is_finite() && (0.0..=top).contains(&e)) {
                        fails.push(Failure {
                            check: "epd_albedo finite in [0, 1]",
                            at: at.clone(),
                            detail: format!("{e}"),
                        });
                    }
                    if theta > 0.0 && !end && (near[k] - e).abs() > 1e-6 {
                        fails.push(Failure {
                            check: "epd_albedo continuous in theta_i",
                            at,
                            detail: format!("{e} vs {}", near[k]),
                        });
                    }
                }
            }
            (n_beta * (2 * inside.len() + beyond.len()), fails)
        })
        .collect();
    results.into_iter().fold((0, Vec::new()), |(n, mut f), (m, g)| {
        f.extend(g);
        (n + m, f)
    })
}

/// All cases; `quick` is the short version `make test` runs.
pub fn run(quick: bool) -> Value {
    let (ne, fe) = if quick { epd_cases(12, 40) } else { epd_cases(60, 120) };
    let (nk, fk) = if quick { kcorr_cases(20, 6) } else { kcorr_cases(60, 20) };
    let (nl, fl) = if quick { lobe_cases(12) } else { lobe_cases(30) };
    let (nc, fc) = if quick { convolved_cases(6) } else { convolved_cases(16) };
    let (na, fa) = if quick { albedo_cases(6, 4, 16) } else { albedo_cases(16, 8, 40) };
    let failures: Vec<Failure> = fe.into_iter().chain(fk).chain(fl).chain(fc).chain(fa).collect();
    json!({
        "cases": ne + nk + nl + nc + na,
        "failures": failures.len(),
        "by_table": { "epd_g1": ne, "kcorr_renorm": nk, "zh_convolution_lobes": nl, "zh_lobe": nc, "epd_albedo": na },
        "failed": failures.iter().take(200).map(|f| json!({ "check": f.check, "at": f.at, "detail": f.detail })).collect::<Vec<_>>(),
    })
}
