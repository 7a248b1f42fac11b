//! A material's diffraction lobe (docs/maths.md section 8): `zh_lobe`, C over
//! (u, theta_h) at its (c, p, beta), and `zh_lobe_sampling`, for each u the
//! quantile in theta_h of the half-vector density proportional to C.
//!
//! Both come from the zonal-harmonic series of docs/maths.md section 4 at each u node,
//! C(theta) = sum_l pi (2l + 1) H_l P_l(cos theta), H_l = F_l(u, c) G_l(p, beta),
//! summed until the terms left are below TAIL of C(0) (far below the 1e-4 of
//! the peak where the accuracy is measured). The CDF of C sin theta has the
//! closed form pi H_0 (1 - x) + pi sum_{l >= 1} H_l (P_{l-1}(x) - P_{l+1}(x)), x = cos theta.

use super::{built, median, quantile_accuracy, Material, QUANTILE_TARGET};
use crate::accuracy::random_points;
use crate::tables::context::BuildContext;
use crate::tables::zh_fit::Fit;
use crate::tables::zh_grid::{fit_lobe, DEFAULT_DEGREE};
use crate::tables::zh_lobe::DERIVATION;
use crate::tables::zh_math::{fitted_lobe, samples, synthesis_matrix};
use crate::tables::Built;
use anyhow::{bail, Context, Result};
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::derived::{Derivation, Derived, EncodedValue, ValueEncoding};
use twoscale_tables::interp::interpolate;

/// Nodes along u (encoded ln(1 + 4 u^2)) and along the derived angle v_theta (odd: the edge v = 1/2 is a node).
pub const U_NODES: usize = 129;
pub const V_NODES: usize = 1025;
/// Quantile rows: nodes along xi (encoded asin(sqrt(xi))); the CDF is evaluated on
/// the v_theta nodes refined FINE times and inverted by cubic Hermite interpolation.
pub const XI_NODES: usize = 2049;
const FINE: usize = 4;
/// The series stops where the terms left sum below TAIL of C(0): at 1e-4 of the
/// peak, 1e-5 relative (1e-10 is below the coefficients' own noise at L = 2000).
pub const TAIL: f64 = 1e-9;
/// Stored C is floored at FLOOR of its row's maximum (ln C must be finite; far below where accuracy is measured).
pub const FLOOR: f64 = 1e-9;
/// Accuracy targets after interpolation where C >= 1e-4 of its maximum at that u.
pub const P99_TARGET: f64 = 1e-3;
pub const MAX_TARGET: f64 = 3e-3;
/// Reference points: REF_U random u, each at REF_ANGLES random angles (or xi).
const REF_U: usize = 250;
const REF_ANGLES: usize = 8;
const SEED: u64 = 0x6c62;

/// The derived angle of a material: zh_lobe's, with beta and p fixed.
pub fn derivation(m: &Material) -> Derivation {
    let Derivation::AnchoredLobeAngle { k, v_anchor, theta_cap } = DERIVATION else {
        unreachable!("zh_lobe's derivation")
    };
    Derivation::MaterialLobeAngle { edge_d: (m.beta * k.powf(0.5 / m.p)).atan(), v_anchor, theta_cap }
}

/// The terms H_l of one u, truncated where the rest sums below TAIL of C(0); None when L terms do not get there.
fn terms(f: ndarray::ArrayView1<f64>, g: ndarray::ArrayView1<f64>) -> Option<Vec<f64>> {
    let h: Vec<f64> = f.iter().zip(g).map(|(f, g)| f * g).collect();
    let weighted = |l: usize| PI * (2 * l + 1) as f64 * h[l];
    let c0: f64 = (0..h.len()).map(weighted).sum();
    let mut tail = 0.0;
    let mut needed = h.len();
    for l in (0..h.len()).rev() {
        tail += weighted(l).abs();
        if tail > TAIL * c0.abs() {
            break;
        }
        needed = l;
    }
    (needed < h.len()).then(|| h[..needed.max(1)].to_vec())
}

/// The series' terms at each u for the material (reference lobes: `plot`, accuracy).
pub fn series(context: &BuildContext, m: &Material, us: &[f64]) -> Result<Vec<Vec<f64>>> {
    let c = m.c.expect("a diffracting material");
    let g = context.d_coefficients(DEFAULT_DEGREE, &[(m.p, m.beta)]);
    let f = context.s_coefficients(DEFAULT_DEGREE, &us.iter().map(|&u| (u, c)).collect::<Vec<_>>());
    (0..us.len())
        .map(|k| {
            terms(f.row(k), g.row(0))
                .with_context(|| format!("material {:?}: the series at u = {} does not converge", m.name, us[k]))
        })
        .collect()
}

/// C and the unnormalised CDF int_0^theta C sin at each angle, from the terms.
/// The recurrence (l+1) P_{l+1} = (2l+1) x P_l - l P_{l-1} is a chain of dependent divisions per angle, so
/// LANES angles advance side by side (independent chains, and loops that vectorize); each angle's
/// arithmetic is `legendre_all`'s and its sums' order is l's, whatever the lanes.
pub fn lobe_and_cdf(h: &[f64], thetas: &[f64]) -> (Vec<f64>, Vec<f64>) {
    const LANES: usize = 8;
    let (mut lobe, mut cdf) = (Vec::with_capacity(thetas.len()), Vec::with_capacity(thetas.len()));
    for chunk in thetas.chunks(LANES) {
        let mut x = [0.0; LANES];
        for (x, &th) in x.iter_mut().zip(chunk) {
            *x = (FRAC_PI_2 - th).sin();
        }
        // P_{l-1}, P_l and P_{l+1} at each angle.
        let (mut prev, mut cur, mut next) = ([0.0; LANES], [1.0; LANES], x);
        let mut c = [0.0; LANES];
        let mut f: [f64; LANES] = std::array::from_fn(|k| PI * h[0] * (1.0 - x[k]));
        for (l, &hl) in h.iter().enumerate() {
            let w = PI * (2 * l + 1) as f64 * hl;
            for k in 0..LANES {
                c[k] += w * cur[k];
            }
            if l >= 1 {
                let w = PI * hl;
                for k in 0..LANES {
                    f[k] += w * (prev[k] - next[k]);
                }
            }
            let lf = (l + 1) as f64;
            for k in 0..LANES {
                let p = ((2.0 * lf + 1.0) * x[k] * next[k] - lf * cur[k]) / (lf + 1.0);
                (prev[k], cur[k], next[k]) = (cur[k], next[k], p);
            }
        }
        lobe.extend_from_slice(&c[..chunk.len()]);
        cdf.extend_from_slice(&f[..chunk.len()]);
    }
    (lobe, cdf)
}

/// The u axis of a material: [0, b / lambda_min].
pub fn u_axis(m: &Material, n: usize) -> Axis {
    Axis::uniform("u", AxisEncoding::Log1pSq { scale: 0.5 }, 0.0, m.b_over_lambda().1, n)
}

/// The quantiles xi -> theta of one row, from the CDF F and density C sin at increasing angles.
fn quantiles(thetas: &[f64], c: &[f64], cdf: &[f64], xis: &[f64]) -> Vec<f32> {
    let total = *cdf.last().expect("angles");
    let density: Vec<f64> = thetas.iter().zip(c).map(|(t, c)| c.max(0.0) * t.sin() / total).collect();
    let f: Vec<f64> = cdf.iter().map(|x| x / total).collect();
    xis.iter()
        .map(|&xi| {
            if xi <= 0.0 {
                return 0.0;
            }
            if xi >= 1.0 {
                return FRAC_PI_2 as f32;
            }
            let j = f.partition_point(|&x| x < xi).clamp(1, f.len() - 1) - 1;
            // Cubic Hermite of F on [theta_j, theta_j+1] (values and the density), inverted by bisection.
            let (t0, t1) = (thetas[j], thetas[j + 1]);
            let hw = t1 - t0;
            let hermite = |s: f64| {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * f[j]
                    + (s3 - 2.0 * s2 + s) * hw * density[j]
                    + (-2.0 * s3 + 3.0 * s2) * f[j + 1]
                    + (s3 - s2) * hw * density[j + 1]
            };
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if hermite(mid) < xi {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (t0 + 0.5 * (lo + hi) * hw) as f32
        })
        .collect()
}

/// Nodes of zh_convolution's u axis (encoded ln(1 + u), as the default preset's).
pub const FIT_U_NODES: usize = 129;
const FIT_REF_U: usize = 2000;

/// `zh_convolution` of a material: the fitted K-correlation lobes of docs/maths.md section 4 (s, g; s_cos, g_cos) over u,
/// fitted at each node to C at the 1000 fit samples, warm-started along u.
pub fn fits_table(context: &BuildContext, m: &Material) -> Result<Built> {
    let start = Instant::now();
    let c = m.c.expect("a diffracting material");
    let u = Axis::uniform("u", AxisEncoding::ShiftedLog { shift: -1.0 }, 0.0, m.b_over_lambda().1, FIT_U_NODES);
    let g = context.d_coefficients(DEFAULT_DEGREE, &[(m.p, m.beta)]);
    // C at the fit samples for each u: the truncated terms of every u times
    // pi (2l + 1) P_l at the samples, one coefficient computation and one matrix product for all of them.
    let q = synthesis_matrix(DEFAULT_DEGREE);
    let curves_at = |us: &[f64]| -> Result<Vec<Vec<f64>>> {
        let f = context.s_coefficients(DEFAULT_DEGREE, &us.iter().map(|&uk| (uk, c)).collect::<Vec<_>>());
        let mut h = ndarray::Array2::zeros((us.len(), DEFAULT_DEGREE));
        let mut needed = 1;
        for k in 0..us.len() {
            let Some(t) = terms(f.row(k), g.row(0)) else {
                bail!("material {:?}: the lobe at u = {} is too sharp for the series", m.name, us[k])
            };
            needed = needed.max(t.len());
            h.row_mut(k).slice_mut(ndarray::s![..t.len()]).assign(&ndarray::ArrayView1::from(t.as_slice()));
        }
        // Only the first `needed` degrees are nonzero in any row: the product over them alone.
        let c = h.slice(ndarray::s![.., ..needed]).dot(&q.slice(ndarray::s![..needed, ..]));
        Ok(c.rows().into_iter().map(|r| r.to_vec()).collect())
    };
    let curves = curves_at(&u.nodes)?;
    let mut fits: Vec<(Fit, Fit)> = Vec::with_capacity(u.len());
    for curve in &curves {
        let previous = fits.last().copied();
        fits.push(fit_lobe(curve, c, previous));
    }
    let column = |f: fn(&(Fit, Fit)) -> f64| {
        ArrayD::from_shape_vec(IxDyn(&[u.len()]), fits.iter().map(|x| f(x) as f32).collect()).expect("shape")
    };
    let values = vec![
        ("s", column(|f| f.0.s)),
        ("g", column(|f| f.0.g)),
        ("s_cos", column(|f| f.1.s)),
        ("g_cos", column(|f| f.1.g)),
    ];
    let compute_seconds = start.elapsed().as_secs_f64();
    // At random u: the lobe from the interpolated fits against the lobe fitted there, and that fit against C.
    let start = Instant::now();
    let axes = vec![u.clone()];
    let ref_u: Vec<f64> = random_points(&axes, FIT_REF_U, SEED + 11).into_iter().map(|p| p[0]).collect();
    // Half the probes are cell centres, so most of those repeat (128 cells): each distinct u is fitted once, and
    // the statistics are taken over all FIT_REF_U probes, repeats included.
    let mut distinct = ref_u.clone();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let ref_curves = curves_at(&distinct)?;
    let distinct_rows: Vec<(f64, f64, f64)> = distinct
        .par_iter()
        .zip(&ref_curves)
        .map(|(&uk, curve)| {
            let at = |name: &str| {
                interpolate(&axes, &values.iter().find(|v| v.0 == name).expect("value").1.view(), &[uk])
                    .expect("inside")
            };
            // Warm-started from the interpolated fits, as the table's nodes are from their neighbour's: the same optimum, sooner.
            let start = |s: f64, g: f64| Fit {
                s,
                g,
                converged: true,
                iterations: 0,
                evaluations: 0,
                rel_l2: 0.0,
                rel_max: 0.0,
            };
            let (plain, cos) = fit_lobe(curve, c, Some((start(at("s"), at("g")), start(at("s_cos"), at("g_cos")))));
            let interp = |s: f64, g: f64, with_cos: bool| {
                samples()
                    .iter()
                    .map(move |&(s2, c2)| fitted_lobe(s, g, c, s2, if with_cos { c2 } else { 1.0 }))
                    .collect::<Vec<_>>()
            };
            let diff = |a: &[f64], b: &[f64]| {
                let max = b.iter().fold(0.0f64, |m, &x| m.max(x));
                a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / max
            };
            let direct_plain = interp(plain.s, plain.g, false);
            let direct_cos = interp(cos.s, cos.g, true);
            let plain_err = diff(&interp(at("s"), at("g"), false), &direct_plain);
            let cos_err = diff(&interp(at("s_cos"), at("g_cos"), true), &direct_cos);
            (plain_err, cos_err, cos.rel_l2)
        })
        .collect();
    let rows: Vec<(f64, f64, f64)> = ref_u
        .iter()
        .map(|u| distinct_rows[distinct.binary_search_by(|x| x.total_cmp(u)).expect("a probe's u")])
        .collect();
    let stat = |k: usize| {
        let v: Vec<f64> = rows.iter().map(|r| [r.0, r.1, r.2][k]).collect();
        json!({ "max": v.iter().fold(0.0f64, |m, &x| m.max(x)), "median": median(&v) })
    };
    let residual: Vec<f64> = fits.iter().map(|f| f.1.rel_l2).collect();
    let accuracy = json!({
        "what": format!("at {FIT_REF_U} random u (half uniform in the encoding, half at cell centres): the fitted lobe from the \
                         interpolated values against the lobe fitted at that u, max over the 1000 angles of docs/maths.md section 4 \
                         relative to the lobe's maximum (interpolation); and the cos fit's relative L2 residual against C \
                         (the paper's representation error, not the table's)"),
        "interpolation_plain": stat(0),
        "interpolation_cos": stat(1),
        "fit_residual_cos_rel_l2_at_random_u": stat(2),
        "fit_residual_cos_rel_l2_at_nodes": { "max": residual.iter().fold(0.0f64, |m, &x| m.max(x)), "median": median(&residual) },
        "converged": fits.iter().all(|f| f.0.converged && f.1.converged),
    });
    let settings = json!({ "u_nodes": FIT_U_NODES, "degree": DEFAULT_DEGREE, "tail": TAIL });
    let values = values.into_iter().collect();
    Ok(built(
        m,
        "zh_convolution",
        axes,
        values,
        accuracy,
        settings,
        compute_seconds,
        start.elapsed().as_secs_f64(),
        Default::default(),
    ))
}

/// Both tables of a material: (zh_lobe, zh_lobe_sampling).
pub fn tables(context: &BuildContext, m: &Material) -> Result<(Built, Built)> {
    tables_sized(context, m, [U_NODES, V_NODES, XI_NODES])
}

/// Both tables with `sizes` = (u, v_theta, xi) nodes (`twoscale bench` sweeps them; v_theta odd).
pub fn tables_sized(context: &BuildContext, m: &Material, sizes: [usize; 3]) -> Result<(Built, Built)> {
    let [n_u, n_v, n_xi] = sizes;
    let start = Instant::now();
    let c = m.c.expect("a diffracting material");
    let derivation = derivation(m);
    let u = u_axis(m, n_u);
    let v = Axis::uniform("v_theta", AxisEncoding::Linear, 0.0, 1.0, n_v);
    let xi = Axis::uniform("xi", AxisEncoding::AsinSqrt, 0.0, 1.0, n_xi);
    let g = context.d_coefficients(DEFAULT_DEGREE, &[(m.p, m.beta)]);
    let uc: Vec<(f64, f64)> = u.nodes.iter().map(|&u| (u, c)).collect();
    let f = context.s_coefficients(DEFAULT_DEGREE, &uc);
    let fine = Axis::uniform("v", AxisEncoding::Linear, 0.0, 1.0, FINE * (n_v - 1) + 1);
    let rows: Vec<Option<(Vec<f32>, Vec<f32>)>> = (0..u.len())
        .into_par_iter()
        .map(|i| {
            let h = terms(f.row(i), g.row(0))?;
            let inputs = [u.nodes[i]];
            let thetas: Vec<f64> = fine.nodes.iter().map(|&v| derivation.inverse(v, &inputs)).collect();
            let (lobe, cdf) = lobe_and_cdf(&h, &thetas);
            let on_nodes: Vec<f64> = lobe.iter().step_by(FINE).copied().collect();
            let floor = FLOOR * on_nodes.iter().fold(0.0f64, |m, &x| m.max(x));
            let ln_c = on_nodes.iter().map(|&x| x.max(floor).ln() as f32).collect();
            Some((ln_c, quantiles(&thetas, &lobe, &cdf, &xi.nodes)))
        })
        .collect();
    let Some(rows) = rows.into_iter().collect::<Option<Vec<_>>>() else {
        bail!("material {:?}: the lobe at u up to {} is too sharp for the zonal-harmonic series to degree {DEFAULT_DEGREE}", m.name, m.b_over_lambda().1)
    };
    let compute_seconds = start.elapsed().as_secs_f64();
    let lobe =
        ArrayD::from_shape_vec(IxDyn(&[u.len(), v.len()]), rows.iter().flat_map(|r| r.0.iter().copied()).collect())
            .expect("shape");
    let sampling =
        ArrayD::from_shape_vec(IxDyn(&[u.len(), xi.len()]), rows.iter().flat_map(|r| r.1.iter().copied()).collect())
            .expect("shape");

    // The references: at REF_U random u, the series from that u's own coefficients.
    let start = Instant::now();
    let ref_u: Vec<f64> = random_points(std::slice::from_ref(&u), REF_U, SEED).into_iter().map(|p| p[0]).collect();
    let f_ref = context.s_coefficients(DEFAULT_DEGREE, &ref_u.iter().map(|&u| (u, c)).collect::<Vec<_>>());
    let lobe_axes = vec![u.clone(), v.clone()];
    let sampling_axes = vec![u.clone(), xi.clone()];
    let probe_v = Axis::uniform("v", AxisEncoding::Linear, 0.0, 1.0, 257);
    // Per reference u: the lobe's relative errors, and (xi, |F_u(theta(u, xi)) - xi|).
    type Measured = (Vec<f64>, Vec<(f64, f64)>);
    let measured: Vec<Measured> = ref_u
        .par_iter()
        .enumerate()
        .map(|(k, &uk)| {
            let h = terms(f_ref.row(k), g.row(0)).expect("converged at the nodes, so between them");
            let inputs = [uk];
            // Angles: REF_ANGLES random v (half at cell centres), and a dense set for the maximum.
            let vs: Vec<f64> = random_points(std::slice::from_ref(&v), REF_ANGLES, SEED + 1 + k as u64)
                .into_iter()
                .map(|p| p[0])
                .collect();
            let angles: Vec<f64> = vs.iter().chain(&probe_v.nodes).map(|&v| derivation.inverse(v, &inputs)).collect();
            let (exact, _) = lobe_and_cdf(&h, &angles);
            let max = exact.iter().fold(0.0f64, |m, &x| m.max(x));
            let lobe_errors = (0..REF_ANGLES)
                .filter(|&j| exact[j] >= 1e-4 * max)
                .map(|j| {
                    (interpolate(&lobe_axes, &lobe.view(), &[uk, vs[j]]).expect("inside").exp() - exact[j]).abs()
                        / exact[j]
                })
                .collect();
            // The quantile at random xi against this u's own CDF.
            let xis: Vec<f64> = random_points(std::slice::from_ref(&xi), REF_ANGLES, SEED + 7 + k as u64)
                .into_iter()
                .map(|p| p[0])
                .collect();
            let thetas: Vec<f64> =
                xis.iter().map(|&x| interpolate(&sampling_axes, &sampling.view(), &[uk, x]).expect("inside")).collect();
            let (_, cdf) = lobe_and_cdf(&h, &thetas.iter().copied().chain([FRAC_PI_2]).collect::<Vec<_>>());
            let total = cdf[REF_ANGLES];
            (lobe_errors, xis.iter().zip(&cdf).map(|(&x, &f)| (x, (f / total - x).abs())).collect())
        })
        .collect();
    let mut pooled: Vec<f64> = measured.iter().flat_map(|m| m.0.iter().copied()).collect();
    pooled.sort_by(f64::total_cmp);
    let at = |q: f64| pooled[((pooled.len() - 1) as f64 * q).round() as usize];
    let lobe_accuracy = json!({
        "what": format!("pointwise relative error of the lookup (bilinear in ln C over the encoded u and the derived \
                         v_theta, then exp) at {} random (u, theta_h): {REF_U} random u (half uniform in the encoding, half \
                         at cell centres) times {REF_ANGLES} random v_theta each, where C >= 1e-4 of its maximum at that u \
                         (over 257 angles), against C by the zonal-harmonic series to degree {DEFAULT_DEGREE} from that u's \
                         own coefficients, summed until the terms left are below {TAIL:e} of C(0)", REF_U * REF_ANGLES),
        "samples": pooled.len(),
        "median": at(0.5),
        "p99": at(0.99),
        "max": at(1.0),
        "targets": { "p99": P99_TARGET, "max": MAX_TARGET },
    });
    let quantile_errors: Vec<(f64, f64)> = measured.iter().flat_map(|m| m.1.iter().copied()).collect();
    let sampling_accuracy = quantile_accuracy(
        &quantile_errors,
        "|F_u(theta(u, xi)) - xi| at random (u, xi) (the u of zh_lobe's accuracy, random xi half uniform in asin(sqrt(xi)), half at \
         cell centres), theta(u, xi) the lookup (bilinear in the encoded u and asin(sqrt(xi))), F_u the CDF of C(theta_h; u) sin \
         theta_h over [0, pi/2] in closed form from that u's own zonal-harmonic terms",
    );
    let accuracy_seconds = start.elapsed().as_secs_f64();
    let settings = json!({
        "degree": DEFAULT_DEGREE,
        "tail": TAIL,
        "floor": format!("C below {FLOOR:e} of its row's maximum is stored as that fraction"),
        "u_nodes": n_u,
        "v_theta_nodes": n_v,
    });
    let derived = Derived {
        axes: vec![derivation.describe("v_theta", "theta_h")],
        values: vec![EncodedValue {
            value: "c_lobe".into(),
            encoding: ValueEncoding::Ln,
            control_variates: vec![],
            formula: "c_lobe = exp(stored): the stored value is ln C, interpolated bilinearly".into(),
        }],
        ..Derived::default()
    };
    let lobe_built = built(
        m,
        "zh_lobe",
        lobe_axes.clone(),
        vec![("c_lobe", lobe)],
        lobe_accuracy,
        settings,
        compute_seconds,
        accuracy_seconds,
        derived,
    );
    let sampling_settings = json!({
        "u_nodes": n_u,
        "xi_nodes": n_xi,
        "target_density": "the half vector h distributed as C(theta_h; u) in solid angle over the upper hemisphere: theta_h \
                           with density C(theta_h; u) sin theta_h / int_0^(pi/2) C sin, phi uniform",
        "sampled_density": super::SAMPLED_DENSITY_2D,
        "cdf": format!("closed form from the zonal-harmonic terms on the v_theta nodes refined {FINE} times, inverted by cubic \
                        Hermite interpolation of the CDF (values and density)"),
        "quantile_target": QUANTILE_TARGET,
    });
    let sampling_built = built(
        m,
        "zh_lobe_sampling",
        sampling_axes,
        vec![("theta_h", sampling)],
        sampling_accuracy,
        sampling_settings,
        0.0,
        0.0,
        Default::default(),
    );
    Ok((lobe_built, sampling_built))
}

#[cfg(test)]
mod tests {
    use super::lobe_and_cdf;
    use crate::numerics::legendre::legendre_all;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn laned_sums_are_the_per_angle_sums_bit_for_bit() {
        // Terms of a decaying lobe; 19 angles (two full chunks of lanes and a partial one).
        let h: Vec<f64> = (0..300).map(|l| (-(l as f64) / 40.0).exp() / (1.0 + l as f64)).collect();
        let thetas: Vec<f64> = (0..19).map(|k| FRAC_PI_2 * k as f64 / 18.0).collect();
        let (lobe, cdf) = lobe_and_cdf(&h, &thetas);
        let mut p = vec![0.0; h.len() + 2];
        for (k, &th) in thetas.iter().enumerate() {
            let x = (FRAC_PI_2 - th).sin();
            legendre_all(x, &mut p);
            let mut c = 0.0;
            let mut f = PI * h[0] * (1.0 - x);
            for l in 0..h.len() {
                c += PI * (2 * l + 1) as f64 * h[l] * p[l];
                if l >= 1 {
                    f += PI * h[l] * (p[l - 1] - p[l + 1]);
                }
            }
            assert_eq!((lobe[k].to_bits(), cdf[k].to_bits()), (c.to_bits(), f.to_bits()), "angle {th}");
        }
    }
}
