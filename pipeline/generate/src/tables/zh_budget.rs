//! zh_convolution's error budget, recorded in its manifest (`accuracy`):
//! coefficient convergence, truncation of C_L against C, fit residuals, and
//! (default preset) the error after interpolating the stored parameters,
//! against the exact C.

use super::options::Method;
use super::preset::Preset;
use super::zh_grid::{
    all_coefficients, auto_degree, comparison_samples, d_coefficients, fit_value, s_coefficients, Grid, NodeFit,
    Samples, EXACT_REL_TOL,
};
use super::zh_math::{exact_convolution, lobe_error, synthesis_matrix, ThetaRule};
use crate::accuracy::{random_points, PROBE_SEED};
use ndarray::{Array2, ArrayD};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::f64::consts::PI;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::lobe::LobeParams;

/// Largest relative difference between two coefficient tables (per row, relative to the row's max).
fn max_row_difference(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    a.rows()
        .into_iter()
        .zip(b.rows())
        .map(|(ra, rb)| {
            let scale = ra.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            ra.iter().zip(rb.iter()).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
        })
        .fold(0.0, f64::max)
}

/// (max, median) of a list, and the index of the max.
fn max_median(v: &[f64]) -> (f64, f64, usize) {
    let mut sorted = v.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (imax, max) = v.iter().enumerate().fold((0, f64::NEG_INFINITY), |b, (i, &x)| if x > b.1 { (i, x) } else { b });
    (max, sorted[sorted.len() / 2], imax)
}

fn point_json(axes: &[Axis], pt: &[f64]) -> Value {
    let m: serde_json::Map<String, Value> = axes.iter().zip(pt).map(|(a, x)| (a.name.clone(), json!(x))).collect();
    Value::Object(m)
}

/// Summary of one error measure over nodes: max, median and the worst node.
fn summary(axes: &[Axis], values: &[f64], points: &[Vec<f64>]) -> Value {
    let (max, median, i) = max_median(values);
    json!({ "max": max, "median": median, "worst": point_json(axes, &points[i]) })
}

/// The error budget of docs/maths.md section 4 / the issue: coefficient convergence,
/// truncation of C_L against C, fit residuals, and (default preset) the error
/// after interpolating the stored parameters, against the exact C.
#[allow(clippy::too_many_arguments)]
pub(super) fn error_budget(
    grid: &Grid,
    preset: Preset,
    degree: usize,
    method: Method,
    rule: &ThetaRule,
    node: &[NodeFit],
    values: &[(String, ArrayD<f32>)],
    smp: &Samples,
) -> Value {
    let axes = &grid.axes;
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let point_of = |flat: usize| -> (Vec<usize>, Vec<f64>) {
        let mut idx = vec![0; 4];
        let mut rem = flat;
        for d in (0..4).rev() {
            idx[d] = rem % shape[d];
            rem /= shape[d];
        }
        let pt = (0..4).map(|d| axes[d].nodes[idx[d]]).collect();
        (idx, pt)
    };
    let points: Vec<Vec<f64>> = (0..node.len()).map(|k| point_of(k).1).collect();

    // Fit residuals over every node.
    let col = |f: fn(&NodeFit) -> f64| node.iter().map(f).collect::<Vec<f64>>();
    let fits = json!({
        "what": "fitted lobe against the convolution it was fitted to (C_L, or C where computed exactly), over \
                 the 1000 samples: relative L2 = |model - C|_2 / |C|_2, relative max = max|model - C| / max|C|",
        "plain_rel_l2": summary(axes, &col(|r| r.plain.rel_l2), &points),
        "plain_rel_max": summary(axes, &col(|r| r.plain.rel_max), &points),
        "cos_rel_l2": summary(axes, &col(|r| r.cos.rel_l2), &points),
        "cos_rel_max": summary(axes, &col(|r| r.cos.rel_max), &points),
        "non_converged": node.iter().filter(|r| !r.plain.converged).count() + node.iter().filter(|r| !r.cos.converged).count(),
        "max_iterations": node.iter().map(|r| r.plain.iterations.max(r.cos.iterations)).max(),
        "mean_iterations": node.iter().map(|r| (r.plain.iterations + r.cos.iterations) as f64).sum::<f64>() / (2 * node.len()) as f64,
        "mean_evaluations": node.iter().map(|r| (r.plain.evaluations + r.cos.evaluations) as f64).sum::<f64>() / (2 * node.len()) as f64,
        "unrepresentable": {
            "what": "nodes whose best lobe misses C by more than half (relative L2 > 0.5): there C does not peak \
                     at theta = 0 (small p with large beta puts the NDF's mass at grazing normals), which no \
                     K-correlation lobe can follow; the paper's beta_max(p) keeps its grid out of that region",
            "plain": node.iter().filter(|r| r.plain.rel_l2 > 0.5).count(),
            "cos": node.iter().filter(|r| r.cos.rel_l2 > 0.5).count(),
        },
    });

    let ks = comparison_samples();
    let beta_at = |idx: &[usize]| grid.beta[[idx[2], idx[3]]];
    let exact_at = |pt: &[f64], beta: f64| -> Vec<f64> {
        ks.iter()
            .map(|&k| {
                exact_convolution(smp.theta[k], &LobeParams { u: pt[0], c: pt[1], p: pt[2], beta }, EXACT_REL_TOL)
            })
            .collect()
    };

    // Truncation of C_L at the 16 corners and 16 random nodes.
    let mut subset: Vec<usize> = (0..16)
        .map(|corner: usize| {
            let idx: Vec<usize> = (0..4).map(|d| if corner >> d & 1 == 1 { shape[d] - 1 } else { 0 }).collect();
            ((idx[0] * shape[1] + idx[1]) * shape[2] + idx[2]) * shape[3] + idx[3]
        })
        .collect();
    let mut rng = crate::numerics::sampling::SplitMix64::new(PROBE_SEED);
    subset.extend((0..16).map(|_| (rng.uniform() * node.len() as f64) as usize % node.len()));
    let truncation = (method != Method::Exact).then(|| {
        let q = synthesis_matrix(degree);
        let weight: Vec<f64> = (0..degree).map(|l| PI * (2 * l + 1) as f64).collect();
        // The coefficients of these nodes only (a row does not depend on the others).
        let w = rule.weighted_legendre(degree);
        let at: Vec<(Vec<usize>, Vec<f64>)> = subset.iter().map(|&k| point_of(k)).collect();
        let f = s_coefficients(rule, &w, &at.iter().map(|(_, pt)| (pt[0], pt[1])).collect::<Vec<_>>());
        let g = d_coefficients(rule, &w, &at.iter().map(|(idx, pt)| (pt[2], beta_at(idx))).collect::<Vec<_>>());
        let rows: Vec<f64> = subset
            .par_iter()
            .enumerate()
            .map(|(i, &k)| {
                if node[k].exact {
                    return 0.0; // computed by the direct integral itself
                }
                let (idx, pt) = &at[i];
                let (fr, gr) = (f.row(i), g.row(i));
                let h = (&fr * &gr).to_vec();
                // The degree this node's sum used.
                let used = if method == Method::Auto { auto_degree(&h, &weight) } else { degree };
                let exact = exact_at(pt, beta_at(idx));
                let max_c = exact.iter().fold(0.0f64, |m, x| m.max(*x));
                ks.iter()
                    .zip(&exact)
                    .map(|(&k, e)| ((0..used).map(|l| h[l] * q[[l, k]]).sum::<f64>() - e).abs())
                    .fold(0.0, f64::max)
                    / max_c
            })
            .collect();
        let sub_points: Vec<Vec<f64>> = subset.iter().map(|&k| points[k].clone()).collect();
        json!({
            "what": format!("max over 24 angles (sin theta_k, k = 999 - round(999 (i/23)^2)) of |C_used - C| / max C, \
                             C by the direct 2-D integral (rel. tol. {EXACT_REL_TOL:e}), C_used the zonal-harmonic sum \
                             the node used (degree L = {degree}, or less under `auto`; 0 where the node was computed \
                             by the direct integral), at the 16 corners of the grid and 16 random nodes"),
            "nodes": subset.len(),
            "summary": summary(axes, &rows, &sub_points),
        })
    });

    let (f1, f2) = {
        // Convergence of the coefficients: standard rule against a refined one, for the sharpest lobes.
        let refined = ThetaRule::refined(degree);
        let ends = |a: &Axis| vec![a.nodes[0], a.nodes[a.len() - 1]];
        let corner = Grid {
            axes: vec![
                Axis::new(
                    "u",
                    {
                        let mut v = ends(&axes[0]);
                        v.sort_by(f64::total_cmp);
                        v
                    },
                    AxisEncoding::Linear,
                ),
                Axis::new(
                    "c",
                    {
                        let mut v = ends(&axes[1]);
                        v.sort_by(f64::total_cmp);
                        v
                    },
                    AxisEncoding::Linear,
                ),
                Axis::new(
                    "p",
                    {
                        let mut v = ends(&axes[2]);
                        v.sort_by(f64::total_cmp);
                        v
                    },
                    AxisEncoding::Linear,
                ),
                Axis::new("b", vec![0.0, 1.0], AxisEncoding::Linear),
            ],
            beta: {
                let (bmin, bmax) = grid.beta.iter().fold((f64::INFINITY, 0.0f64), |m, &b| (m.0.min(b), m.1.max(b)));
                Array2::from_shape_fn((2, 2), |(_, m)| if m == 0 { bmin } else { bmax })
            },
        };
        let (fa, ga) = all_coefficients(&corner, rule, degree);
        let (fb, gb) = all_coefficients(&corner, &refined, degree);
        (max_row_difference(&fa, &fb), max_row_difference(&ga, &gb))
    };

    let mut budget = json!({
        "coefficients": {
            "what": "max over l < L' and over the extreme lobes (u, c at the ends of their axes; p, beta at theirs) of \
                     |F_l - F_l'| / max|F| and |G_l - G_l'| / max|G|, F' G' from a refined rule (32 nodes per panel, \
                     ratio 1.12, step 0.01)",
            "f_max_rel_change": f1,
            "g_max_rel_change": f2,
        },
        "fit_residual": fits,
        "nodes_computed_exactly": node.iter().filter(|r| r.exact).count(),
    });
    if let Some(t) = truncation {
        budget["truncation"] = t;
    }

    if preset == Preset::Default {
        // What a renderer sees: interpolated (s, g) lobes against the exact C.
        let probes = random_points(axes, 24, PROBE_SEED ^ 0x5a5a);
        let errs: Vec<(f64, f64)> = probes
            .par_iter()
            .map(|pt| {
                let v: Vec<f64> = ["s", "g", "s_cos", "g_cos"]
                    .iter()
                    .map(|name| fit_value(axes, values, name, pt).expect("inside"))
                    .collect();
                let exact = exact_at(pt, pt[3]);
                (lobe_error(v[0], v[1], pt[1], false, &ks, &exact), lobe_error(v[2], v[3], pt[1], true, &ks, &exact))
            })
            .collect();
        budget["interpolated_vs_exact"] = json!({
            "what": "the lobe from (s, g) (and from (s_cos, g_cos)) interpolated multilinearly in encoded coordinates (s and s_cos in ln) \
                     at 24 random off-grid points, against the exact C at the 24 angles: max |lobe - C| / max C",
            "plain": summary(axes, &errs.iter().map(|e| e.0).collect::<Vec<_>>(), &probes),
            "cos": summary(axes, &errs.iter().map(|e| e.1).collect::<Vec<_>>(), &probes),
        });
    }
    budget
}
