//! Table `zh_lobe` (docs/maths.md section 4b): the convolved lobe C(theta_h; u, c, p,
//! beta) itself, so that a renderer reconstructs it tails included instead of
//! through one fitted K-correlation lobe. Built by the `zh-convolution` stage.
//!
//! Representation (measured against C computed independently, see `accuracy`):
//! - the angle is stored in two pieces joined at the lobe's closed-form edge
//!   theta_a(u, beta, p) (`derived::Derivation::AnchoredLobeAngle`): the edge
//!   sits at v = 1/2 at every node, so interpolating across beta and p does not
//!   smear it (halves the error along beta), the core is resolved at the
//!   lobe's own scale and the tail spaced logarithmically;
//! - u is stored as ln(1 + 4 u^2), the variable the K-correlation lobe depends
//!   on (with only u off-grid, p99 5.5 % -> 3.9 % against ln(u + 1) at 17
//!   nodes);
//! - p is stored as ln(p - 0.1): the EPD's width goes as k^(1/(2p)), which
//!   moves fastest at small p, where ln p left too few nodes;
//! - the value is stored as ln C, in which the power-law tail of the
//!   K-correlation is linear in c and the EPD's exp(-(tan/beta)^(2p)) is smooth,
//!   and decoded with closed-form control variates (`twoscale_tables::lobe`),
//!   stored at the nodes beside it (four more values of the same shape);
//! - grid 17 (u) x 8 (c) x 41 (p) x 23 (beta) x 121 (v) = 15.5 M entries,
//!   62 MB; the odd count of v nodes puts the edge v = 1/2, where dtheta/dv
//!   jumps, on a node instead of inside a cell.
//!
//! C at the nodes is the zonal-harmonic sum of `zh_math` (same rule, degree and
//! `auto` convergence test as `zh_convolution`; the direct integral where the
//! series has not converged by L), evaluated by matrix products per (p, beta).

use super::context::BuildContext;
use super::job::{Built, Job, Part, Units};
use super::options::{BuildOptions, Method};
use super::preset::Preset;
use super::sub_domain::restrict;
use super::table_def::TableDef;
use super::zh_grid::{
    auto_degree, d_coefficients, fit_value, s_coefficients, Fits, AUTO_TOLERANCE, DEFAULT_DEGREE, EXACT_REL_TOL,
};
use super::zh_math::{exact_convolution, fitted_lobe, samples, synthesis_matrix, ThetaRule};
use crate::accuracy::random_points;
use crate::numerics::legendre::legendre_all;
use crate::progress::Progress;
use anyhow::Result;
use indicatif::ParallelProgressIterator;
use ndarray::{Array2, ArrayD, Axis as NdAxis, IxDyn};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::derived::{ControlVariate, Derivation, Derived, EncodedValue, ValueEncoding};
use twoscale_tables::lobe::{LobeParams, LobeTerms, Term, FORMULA};
use twoscale_tables::table::Table;
use twoscale_tables::Lookup;

pub const ZH_LOBE: TableDef = TableDef {
    name: "zh_lobe",
    stage: "zh-convolution",
    definition: "docs/maths.md section 4b: c_lobe = C(theta_h; u, c, p, beta) = int S(h.m) D(n.m) dm (section 4), stored as \
                 ln C on the derived angle axis v_theta, decoded with closed-form control variates (manifest derived_axes, \
                 value_encoding)",
    axes,
    diffraction: true,
    cubic: false,
    job,
    presets: &[Preset::Default],
};

/// The derived angle: the EPD edge is taken where it falls to 1e-4 (k = ln 1e4);
/// the cap 1.45 was the best of 1.0 .. pi/2 measured (p99 6.2 %, max 15 %).
pub const DERIVATION: Derivation =
    Derivation::AnchoredLobeAngle { k: 9.210340371976184, v_anchor: 0.5, theta_cap: 1.45 };
/// Stored C is floored at this fraction of the node's maximum over the angles:
/// below it the zonal-harmonic sum is at the level of its truncation (AUTO_TAIL).
pub const FLOOR: f64 = 1e-7;
/// Probe points of the accuracy measurement, each compared at the 1000 angles of docs/maths.md section 4.
pub const PROBES: usize = 2000;
pub const PROBE_SEED: u64 = 0x10be;

/// Nodes per axis (u, c, p, beta, v_theta) of the shipped table.
pub const SIZES: [usize; 5] = [17, 8, 41, 23, 121];

/// The table's axes with `sizes` nodes each (`twoscale bench` sweeps them);
/// an odd count of v_theta nodes puts the edge v = 1/2 on a node.
pub fn grid(sizes: [usize; 5]) -> Vec<Axis> {
    assert!(sizes[4] % 2 == 1, "v_theta = 1/2 must be a node");
    vec![
        Axis::uniform("u", AxisEncoding::Log1pSq { scale: 0.5 }, 0.0, 100.0, sizes[0]),
        Axis::uniform("c", AxisEncoding::Linear, 1.02, 3.02, sizes[1]),
        Axis::uniform("p", AxisEncoding::ShiftedLog { shift: 0.1 }, 0.2, 5.0, sizes[2]),
        Axis::uniform("beta", AxisEncoding::Log, 0.005, 0.5, sizes[3]),
        Axis::uniform("v_theta", AxisEncoding::Linear, 0.0, 1.0, sizes[4]),
    ]
}

fn axes(_: Preset) -> Vec<Axis> {
    grid(SIZES)
}

/// pi (2l + 1) P_l(cos theta_j) for l < degree, one row per angle.
fn synthesis_rows(thetas: &[f64], degree: usize) -> Array2<f64> {
    let mut q = Array2::zeros((degree, thetas.len()));
    let mut p = vec![0.0; degree];
    for (j, &th) in thetas.iter().enumerate() {
        legendre_all((FRAC_PI_2 - th).sin(), &mut p);
        for l in 0..degree {
            q[[l, j]] = PI * (2 * l + 1) as f64 * p[l];
        }
    }
    q
}

/// ln C at the angles of one node, C floored at FLOOR of its maximum.
fn ln_floored(c: impl Iterator<Item = f64> + Clone) -> Vec<f32> {
    let floor = FLOOR * c.clone().fold(0.0f64, f64::max);
    c.map(|x| x.max(floor).ln() as f32).collect()
}

fn job(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let (axes, _) = restrict(axes(preset), options)?;
    let degree = options.degree.unwrap_or(DEFAULT_DEGREE);
    Ok(Box::new(LobeJob {
        axes,
        preset,
        degree,
        scene: options.scene.is_some(),
        fit_options: (options.degree, options.method),
        context: options.context.clone(),
    }))
}

/// One unit per (p, beta) pair (ip * n_beta + ib): for each u, C at the node
/// angles of every c by one matrix product.
pub struct LobeJob {
    axes: Vec<Axis>,
    preset: Preset,
    degree: usize,
    scene: bool,
    /// The degree and method options zh_convolution's fitted lobes are built with, for the accuracy.
    fit_options: (Option<usize>, Option<Method>),
    /// The build's shared coefficient rows and fits (none: every compute from cold).
    context: Option<Arc<BuildContext>>,
}

impl LobeJob {
    /// The job on `axes` (a sub-grid of the default domain) at `degree`.
    pub fn on(axes: Vec<Axis>, degree: usize) -> LobeJob {
        LobeJob { axes, preset: Preset::Default, degree, scene: false, fit_options: (None, None), context: None }
    }

    pub fn axes(&self) -> &[Axis] {
        &self.axes
    }

    /// The stored ln C from the parts of every unit: the (p, beta) blocks in
    /// unit order, scattered into (u, c, p, beta, v) order.
    pub fn values(&self, whole: &Part) -> ArrayD<f32> {
        let shape = self.shape();
        let (n_u, n_c, n_p, n_b, n_v) = (shape[0], shape[1], shape[2], shape[3], shape[4]);
        let blocks = &whole.values[0].1;
        let mut data = vec![0.0f32; shape.iter().product()];
        for unit in 0..n_p * n_b {
            let block = &blocks[unit * n_u * n_c * n_v..][..n_u * n_c * n_v];
            for r in 0..n_u * n_c {
                let dst = (r * n_p * n_b + unit) * n_v;
                data[dst..dst + n_v].copy_from_slice(&block[r * n_v..][..n_v]);
            }
        }
        ArrayD::from_shape_vec(IxDyn(&shape), data).expect("shape")
    }

    fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(Axis::len).collect()
    }

    /// ln C at every (u, c, v) of the pair (p, beta), in (u, c, v) order.
    fn pair(&self, f: &Array2<f64>, gl: ndarray::ArrayView1<f64>, p: f64, beta: f64) -> Vec<f32> {
        let (axes, degree) = (&self.axes, self.degree);
        let shape = self.shape();
        let (n_u, n_c, n_v) = (shape[0], shape[1], shape[4]);
        let weight: Vec<f64> = (0..degree).map(|l| PI * (2 * l + 1) as f64).collect();
        let mut out = vec![0.0f32; n_u * n_c * n_v];
        for iu in 0..n_u {
            let u = axes[0].nodes[iu];
            let thetas: Vec<f64> = axes[4].nodes.iter().map(|&v| DERIVATION.inverse(v, &[u, p, beta])).collect();
            let h = Array2::from_shape_fn((n_c, degree), |(ic, l)| f[[iu * n_c + ic, l]] * gl[l]);
            let plan: Vec<usize> = h.rows().into_iter().map(|r| auto_degree(&r.to_vec(), &weight)).collect();
            let needed = plan.iter().copied().max().unwrap_or(1);
            let q = synthesis_rows(&thetas, needed);
            let cl = h.slice(ndarray::s![.., ..needed]).dot(&q);
            let last = degree - degree / 4;
            for ic in 0..n_c {
                let row = cl.index_axis(NdAxis(0), ic);
                // As in `zh_convolution`'s `auto`: the direct integral where the last quarter of the terms still matters.
                let converged = plan[ic] <= last || {
                    let tail = h.slice(ndarray::s![ic, last..needed]).dot(&q.slice(ndarray::s![last.., ..]));
                    let max_c = row.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    tail.iter().fold(0.0f64, |m, x| m.max(x.abs())) <= AUTO_TOLERANCE * max_c
                };
                let c = axes[1].nodes[ic];
                let ln_c = if converged {
                    ln_floored(row.iter().copied())
                } else {
                    let exact: Vec<f64> = thetas
                        .iter()
                        .map(|&th| exact_convolution(th, &LobeParams { u, c, p, beta }, EXACT_REL_TOL))
                        .collect();
                    ln_floored(exact.into_iter())
                };
                out[(iu * n_c + ic) * n_v..][..n_v].copy_from_slice(&ln_c);
            }
        }
        out
    }
}

impl Job for LobeJob {
    fn units(&self) -> usize {
        self.axes[2].len() * self.axes[3].len()
    }

    fn unit_len(&self) -> usize {
        self.axes[0].len() * self.axes[1].len() * self.axes[4].len()
    }

    fn unit_name(&self) -> &'static str {
        "(p, beta) pair (ip * n_beta + ib), entries in (u, c, v_theta) order"
    }

    fn compute(&self, units: Units, progress: Progress) -> Part {
        let axes = &self.axes;
        let n_b = axes[3].len();
        let pairs: Vec<(usize, usize)> = units.iter().map(|k| (k / n_b, k % n_b)).collect();
        // F for every (u, c) is what any set of pairs costs; G for these pairs only.
        let start = Instant::now();
        let uc: Vec<(f64, f64)> =
            axes[0].nodes.iter().flat_map(|&u| axes[1].nodes.iter().map(move |&c| (u, c))).collect();
        let context = self.context.clone().unwrap_or_default();
        let f = context.s_coefficients(self.degree, &uc);
        let setup_seconds = start.elapsed().as_secs_f64();
        let pb: Vec<(f64, f64)> = pairs.iter().map(|&(ip, ib)| (axes[2].nodes[ip], axes[3].nodes[ib])).collect();
        let g = context.d_coefficients(self.degree, &pb);
        let coefficient_seconds = start.elapsed().as_secs_f64();
        let bar = progress.bar("zh_lobe", pairs.len() as u64);
        let blocks: Vec<Vec<f32>> = pb
            .par_iter()
            .enumerate()
            .progress_with(bar.clone())
            .map(|(j, &(p, beta))| self.pair(&f, g.row(j), p, beta))
            .collect();
        bar.finish_and_clear();
        Part {
            values: vec![("c_lobe".to_string(), blocks.concat())],
            compute_seconds: start.elapsed().as_secs_f64(),
            setup_seconds,
            stages: json!({ "coefficients_seconds": coefficient_seconds }),
            ..Part::default()
        }
    }

    fn finish(&self, whole: Part) -> Built {
        let values = lobe_values(&self.axes, self.values(&whole));
        let start = Instant::now();
        let rule = ThetaRule::standard(self.degree);
        let context = self.context.clone().unwrap_or_default();
        let fits = (!self.scene).then(|| super::zh::default_fits(&context, self.fit_options.0, self.fit_options.1));
        let accuracy = accuracy(&lobe_lookup(&self.axes, values.clone()), &rule, self.degree, fits);
        let accuracy_seconds = start.elapsed().as_secs_f64();
        let settings = json!({
            "degree": self.degree,
            "method": "auto (as zh_convolution): per-node degree from the coefficient tail, direct integral where the last quarter of the terms still matters",
            "auto_tolerance": AUTO_TOLERANCE,
            "exact_rel_tol": EXACT_REL_TOL,
            "floor": format!("C below {FLOOR:e} of the node's maximum over the angles is stored as that fraction (the series' truncation level)"),
            "coefficients": format!("composite Gauss-Legendre in theta, {} nodes, to degree {} (as zh_convolution)", rule.len(), self.degree),
        });
        let table =
            Table { name: ZH_LOBE.name.into(), preset: self.preset.name().into(), axes: self.axes.clone(), values };
        Built {
            table,
            accuracy,
            settings,
            compute_seconds: whole.compute_seconds,
            accuracy_seconds,
            stages: whole.stages,
            derived: derived(),
        }
    }
}

/// The derived angle and the decoding of `c_lobe` with its control variates.
fn derived() -> Derived {
    let control_variates = Term::ALL.iter().map(|&term| ControlVariate { term, values: term.values_name() }).collect();
    Derived {
        axes: vec![DERIVATION.describe("v_theta", "theta_h")],
        values: vec![EncodedValue {
            value: "c_lobe".into(),
            encoding: ValueEncoding::Ln,
            control_variates,
            formula: FORMULA.into(),
        }],
        ..Derived::default()
    }
}

/// The stored values: `c_lobe` (ln C at the nodes) and, for its decoding,
/// each control variate's term at the nodes (`Term::values_name`), the
/// node's angle from its v_theta by the derived axis's inverse.
pub fn lobe_values(axes: &[Axis], ln_c: ArrayD<f32>) -> Vec<(String, ArrayD<f32>)> {
    let shape = ln_c.shape().to_vec();
    let n_v = shape[4];
    let rows: Vec<[usize; 4]> = ndarray::indices(&shape[..4]).into_iter().map(|i| [i[0], i[1], i[2], i[3]]).collect();
    let per_row: Vec<Vec<[f64; 4]>> = rows
        .par_iter()
        .map(|&[iu, ic, ip, ib]| {
            let x = LobeParams {
                u: axes[0].nodes[iu],
                c: axes[1].nodes[ic],
                p: axes[2].nodes[ip],
                beta: axes[3].nodes[ib],
            };
            let at = LobeTerms::new(&x);
            axes[4].nodes.iter().map(|&v| at.at(DERIVATION.inverse(v, &x.angle_inputs()), [true; 4])).collect()
        })
        .collect();
    let mut values = vec![("c_lobe".to_string(), ln_c)];
    for (j, term) in Term::ALL.iter().enumerate() {
        let data: Vec<f32> = per_row.iter().flat_map(|row| row.iter().map(move |t| t[j] as f32)).collect();
        debug_assert_eq!(data.len(), rows.len() * n_v);
        values.push((term.values_name(), ArrayD::from_shape_vec(IxDyn(&shape), data).expect("shape")));
    }
    values
}

/// The table's lookup (`twoscale_tables::Lookup`, as every reader decodes it) on values in memory.
pub fn lobe_lookup(axes: &[Axis], values: Vec<(String, ArrayD<f32>)>) -> Lookup {
    let derived = derived();
    Lookup::new(ZH_LOBE.name.into(), axes.to_vec(), values, derived.axes, derived.values, derived.interpolation)
}

/// C at the 1000 angles of docs/maths.md section 4 for every point (u, c, p, beta),
/// independently of any table: each point's own coefficients F_l, G_l (same
/// rule) and the zonal-harmonic sum to `degree`.
pub fn reference(points: &[Vec<f64>], rule: &ThetaRule, degree: usize) -> Array2<f64> {
    let w = rule.weighted_legendre(degree);
    let uc: Vec<(f64, f64)> = points.iter().map(|pt| (pt[0], pt[1])).collect();
    let pb: Vec<(f64, f64)> = points.iter().map(|pt| (pt[2], pt[3])).collect();
    let h = s_coefficients(rule, &w, &uc) * d_coefficients(rule, &w, &pb);
    h.dot(&synthesis_matrix(degree))
}

/// Pointwise relative errors wherever C >= 1e-4 of the point's maximum, and
/// the relative L2 over all 1000 angles, of a lobe model against the reference.
pub struct LobeErrors {
    /// Per point: (max pointwise relative error, relative L2).
    pub per_point: Vec<(f64, f64)>,
    pub pooled: Vec<f64>,
}

pub fn lobe_errors(reference: &Array2<f64>, model: impl Fn(usize, f64) -> f64 + Sync) -> LobeErrors {
    let theta: Vec<f64> = samples().iter().map(|x| x.0.sqrt().asin()).collect();
    let rows: Vec<(f64, f64, Vec<f64>)> = (0..reference.nrows())
        .into_par_iter()
        .map(|i| {
            let r = reference.row(i);
            let max = r.iter().fold(0.0f64, |m, x| m.max(*x));
            let (mut num, mut den, mut errs) = (0.0f64, 0.0f64, Vec::new());
            for (k, &c) in r.iter().enumerate() {
                let m = model(i, theta[k]);
                num += (m - c) * (m - c);
                den += c * c;
                if c >= 1e-4 * max {
                    errs.push((m - c).abs() / c);
                }
            }
            (errs.iter().copied().fold(0.0, f64::max), (num / den).sqrt(), errs)
        })
        .collect();
    LobeErrors {
        per_point: rows.iter().map(|r| (r.0, r.1)).collect(),
        pooled: rows.into_iter().flat_map(|r| r.2).collect(),
    }
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// Quantiles of `LobeErrors`: pooled pointwise, and relative L2 over the points.
pub struct LobeSummary {
    pub samples: usize,
    pub median: f64,
    pub p99: f64,
    pub max: f64,
    pub l2_median: f64,
    pub l2_p90: f64,
    pub l2_max: f64,
}

impl LobeErrors {
    pub fn summary(&self) -> LobeSummary {
        let mut pooled = self.pooled.clone();
        pooled.sort_by(f64::total_cmp);
        let mut l2: Vec<f64> = self.per_point.iter().map(|r| r.1).collect();
        l2.sort_by(f64::total_cmp);
        LobeSummary {
            samples: pooled.len(),
            median: quantile(&pooled, 0.5),
            p99: quantile(&pooled, 0.99),
            max: quantile(&pooled, 1.0),
            l2_median: quantile(&l2, 0.5),
            l2_p90: quantile(&l2, 0.9),
            l2_max: quantile(&l2, 1.0),
        }
    }

    pub fn to_json(&self, points: &[Vec<f64>]) -> Value {
        let s = self.summary();
        let worst = (0..points.len()).max_by(|&a, &b| self.per_point[a].0.total_cmp(&self.per_point[b].0)).unwrap_or(0);
        json!({
            "pointwise": { "samples": s.samples, "median": s.median, "p99": s.p99, "max": s.max },
            "relative_l2": { "median": s.l2_median, "p90": s.l2_p90, "max": s.l2_max },
            "worst_point": { "u": points[worst][0], "c": points[worst][1], "p": points[worst][2], "beta": points[worst][3],
                             "max_pointwise": self.per_point[worst].0 },
        })
    }
}

/// The lobe `table` (`lobe_lookup`) gives at physical (u, c, p, beta) = `pt` and `theta`.
pub fn table_lobe(table: &Lookup, pt: &[f64], theta: f64) -> f64 {
    table.decode(&[pt[0], pt[1], pt[2], pt[3], theta]).expect("probe inside the domain")[0]
}

/// The errors of zh_convolution's fitted lobes (`axes`, `values`) at `points`
/// against `reference`: s and g (s_cos and g_cos if `cos`) interpolated (`fit_value`) once
/// per point, the lobe evaluated at each angle.
pub fn fitted_lobe_errors(
    reference: &Array2<f64>,
    axes: &[Axis],
    values: &[(String, ArrayD<f32>)],
    points: &[Vec<f64>],
    cos: bool,
) -> LobeErrors {
    let at = |name: &str, pt: &[f64]| fit_value(axes, values, name, pt).expect("probe inside the domain");
    let (s, g) = if cos { ("s_cos", "g_cos") } else { ("s", "g") };
    let fits: Vec<(f64, f64)> = points.iter().map(|pt| (at(s, pt), at(g, pt))).collect();
    lobe_errors(reference, |i, th| {
        let sin2 = th.sin().powi(2);
        fitted_lobe(fits[i].0, fits[i].1, points[i][1], sin2, if cos { 1.0 - sin2 } else { 1.0 })
    })
}

/// The error of the stored lobe, and beside it (`fits`: zh_convolution's
/// axes and values on the default domain; none for a scene) that of the fitted lobes.
fn accuracy(lobe: &Lookup, rule: &ThetaRule, degree: usize, fits: Option<Result<Fits>>) -> Value {
    let points = random_points(&lobe.axes[..4], PROBES, PROBE_SEED);
    let reference = reference(&points, rule, degree);
    let table = lobe_errors(&reference, |i, th| table_lobe(lobe, &points[i], th));
    let mut out = json!({
        "what": format!("error after interpolation of the stored lobe (lookup: derived angle, multilinear in ln C with the \
                         control variates of value_encoding, exp) \
                         at {PROBES} random parameter points (half uniform in the encoded axes, half at cell centres), \
                         each at the 1000 angles sin theta_k = 1 - k/1000 of docs/maths.md section 4, against C computed \
                         independently of the table: the zonal-harmonic sum to degree {degree} from the point's own \
                         coefficients (converged: tests check it against the direct 2-D integral). Pointwise relative \
                         error over the (point, angle) samples where C >= 1e-4 of that point's maximum; relative L2 per \
                         point over all 1000 angles"),
        "table": table.to_json(&points),
    });
    // The paper's representation at the same points.
    match fits {
        Some(Ok((fit_axes, fit_values))) => {
            let fits =
                |cos: bool| fitted_lobe_errors(&reference, &fit_axes, &fit_values, &points, cos).to_json(&points);
            out["zh_convolution_fitted_lobes"] = json!({
                "what": "the same measurement, same points, for the lobes of zh_convolution (s, g and s_cos, g_cos interpolated at the point)",
                "plain": fits(false),
                "cos": fits(true),
            });
        }
        Some(Err(e)) => {
            out["zh_convolution_fitted_lobes"] =
                json!(format!("not measured: zh_convolution could not be built: {e:#}"))
        }
        None => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::tables::zh_math::d_lobe;
    use std::f64::consts::FRAC_PI_2;
    use twoscale_tables::lobe::{epd_grazing_peak, ln_d_smoothed, tail_weight};

    #[test]
    fn ln_d_is_the_epd_lobe_where_the_diffraction_core_is_negligible() {
        for &(p, beta) in &[(0.2, 0.005), (1.0, 0.1), (5.0, 0.5), (0.3, 0.3)] {
            for &theta in &[0.05f64, 0.4, 1.2, 1.5] {
                let (s, c) = theta.sin_cos();
                let want = d_lobe(s * s, c * c, p, beta).ln();
                let got = ln_d_smoothed(theta, 1e7, p, beta);
                assert!(
                    (got - want).abs() <= 1e-6 * want.abs().max(1.0),
                    "p {p} beta {beta} theta {theta}: {got} vs {want}"
                );
            }
            // Finite up to the horizon, where D vanishes.
            assert!(ln_d_smoothed(FRAC_PI_2, 100.0, p, beta) < -600.0);
        }
    }

    #[test]
    fn the_tail_weight_reads_the_epd_grazing_peak() {
        // g is ln D at tan theta_pk = beta (2/p)^(1/(2p)), where the two factors balance
        // for tan theta >> 1: there within 0.02 of ln D's local maximum near grazing.
        for &(p, beta) in &[(0.2, 0.33), (0.313, 0.2285), (0.27, 0.0116), (0.5, 0.5)] {
            let tan_pk = beta * (2.0f64 / p).powf(0.5 / p);
            let ln_peak = epd_grazing_peak(p, beta);
            let at = |th: f64| d_lobe(th.sin().powi(2), th.cos().powi(2), p, beta).ln();
            assert!((at(tan_pk.atan()) - ln_peak).abs() < 1e-9 * ln_peak.abs().max(1.0), "p {p} beta {beta}");
            if tan_pk >= 3.0 {
                let from = (0.5 * tan_pk).atan();
                let max = (0..20000)
                    .map(|k| at(from + (FRAC_PI_2 - from) * k as f64 / 20000.0))
                    .fold(f64::NEG_INFINITY, f64::max);
                assert!(
                    max > ln_peak - 1e-6 && max - ln_peak < 0.02,
                    "p {p} beta {beta}: max {max}, closed form {ln_peak}"
                );
            }
        }
        // Inside the cores no tail term; beyond them all of it, unless the peak is large or p >= 2.
        assert_eq!(tail_weight(0.1, 0.4, 0.01), 0.0);
        assert_eq!(tail_weight(0.6, 0.4, 0.01), 1.0); // g = -5 + 2 ln(1 + 5.6e-3)
        assert_eq!(tail_weight(0.6, 0.2, 0.33), 0.0); // D(theta_pk) ~ 1500 D(0)
        assert_eq!(tail_weight(0.6, 2.0, 0.01), 0.0);
        let w = tail_weight(0.35, 0.4, 0.01);
        assert!((w - 0.5).abs() < 1e-12, "{w}");
    }
}
