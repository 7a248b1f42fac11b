//! A material's `albedo` (docs/maths.md section 9): the directional albedo with
//! F = 1 of the whole single-scattering BRDF a runtime evaluates from the material's own tables
//! (`twoscale_tables::brdf`, docs/runtimes.md "eval"),
//!     E(mu, lambda) = int_{o_z > 0} rho(i, o) cos theta_o do,   mu = cos theta_i,
//! tabulated over theta_i (epd_g1's encoding: both normal and grazing incidence resolved), and
//! E_avg(lambda) = 2 int_0^1 E(mu) mu dmu of the table's own interpolant (the value `e_avg`,
//! stored at every theta_i node: the contract has one set of axes per table), so that a
//! compensation lobe (1 - E(i)) (1 - E(o)) / (pi (1 - E_avg)) restores 1 - E(i) (to f32 rounding).
//!
//! E is integrated over the half vector h (theta_h, phi): o = 2 (i.h) h - i, do = 4 (i.h) dh.
//! With i in the xz-plane, o_z > 0 exactly for phi < phi_max(theta_h), cos phi_max =
//! -cot theta_i cot 2 theta_h (no cut below theta_c = pi/4 - theta_i/2, nothing beyond
//! theta_max = pi/4 + theta_i/2), and rho is even in phi: E = 2 int dtheta_h int_0^phi_max dphi.
//! theta_h is integrated in x = ln tan theta_h (the lobes' scales, from beta to pi/2, are
//! logarithmic), composite Gauss-Legendre with breaks at theta_c; phi by Gauss-Legendre on
//! [0, phi_max]. The wavelength-free factors (G2, D, theta_h, cos_d) are shared by every lambda, and
//! the rest is computed for all lambdas at once (`MaterialBrdf::wave_parts`: loops that vectorize).
//! Where the diffraction scale g < 1 (theta_o beyond theta_g), g(theta_o) varies on the scale of its
//! balancing cells, which those panels don't resolve: the pass that computes e and e_comp refines the
//! rule where o reaches beyond theta_g (`Incidence::refine`); g's balancing keeps the plain rule.

use super::{built, median, Material};
use crate::accuracy::random_points;
use crate::numerics::legendre::{composite_rule, gauss_legendre};
use crate::tables::epd_albedo_math::{adaptive, rule_text, theta_average, Incidence, MU_MIN};
use crate::tables::Built;
use anyhow::Result;
use ndarray::{ArrayD, IxDyn};
use rayon::prelude::*;
use serde_json::json;
use std::path::Path;
use std::time::Instant;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::brdf::{MaterialBrdf, Pair, WaveParts};
use twoscale_tables::fresnel;
use twoscale_tables::interp::interpolate;

/// Nodes along theta_i in [0, acos(MU_MIN)], uniform in epd_g1's encoding bounded_log_tan,
/// e = ln((tan theta_i + EPS)/(1 + delta tan theta_i)), delta = DELTA_BETA beta: logarithmic in
/// theta_i near normal incidence (heavy tails, p < 1/2, give E a cusp ~ theta_i^(2p) there) and
/// in mu = cos theta_i ~ cot theta_i near grazing incidence (E changes over mu ~ beta).
pub const THETA_NODES: usize = 1025;
pub const EPS: f64 = 1e-3;
pub const DELTA_BETA: f64 = 0.01;
/// Nodes along lambda (ln lambda) per unit of ln(lambda_max / lambda_min), at least 9.
pub const LAMBDA_NODES_PER_LN: f64 = 48.0;
/// The half-vector rule (`half_vector::Incidence::breaks`): NODES Gauss-Legendre nodes per panel, PHI_NODES in phi.
const NODES: usize = 6;
const PHI_NODES: usize = 12;
/// The refined rule of the e and e_comp pass: between theta_h = max((theta_g - theta_i)/2, FINE_FLOOR) and
/// x = ln tan theta_h = FINE_CEILING every panel split into panels of at most FINE_PANEL (0.25 left 1.2e-4 at chi9),
/// and FINE_PHI_NODES in phi. Below FINE_FLOOR o stays within 0.2 of theta_i, and the coarse rule suffices; above
/// FINE_CEILING (theta_h 70 degrees) too: refining there moved no e_comp of the 9 refined test materials by 3.9e-6
/// (their differences from a rule refined to theta_max in panels of 1/16, 48 phi nodes, stayed the same); a
/// ceiling of 0 nearly doubled chi9's (8.7e-5).
const FINE_PANEL: f64 = 0.125;
const FINE_PHI_NODES: usize = 24;
const FINE_FLOOR: f64 = 0.1;
const FINE_CEILING: f64 = 1.0;
pub const TARGET: f64 = 1e-4;
/// g is balanced on every STRIDE-th theta_i node (a 129-node grid) and interpolated between them.
const STRIDE: usize = 8;
/// The balance stops when no g moves by more than BALANCE_TOL, or after BALANCE_MAX rounds.
const BALANCE_TOL: f64 = 1e-10;
const BALANCE_MAX: usize = 20_000;
pub const PROBES: usize = 512;
/// e_comp's probes: the first of the same points (its reference, with g's kinks, costs ~10 times e's).
const COMP_PROBES: usize = 128;
const REFERENCE_TOL: f64 = 1e-6;
const SEED: u64 = 0x616c;

impl Incidence {
    /// Splits every panel of `breaks` between x0 = ln tan max((theta_g - theta_i)/2, FINE_FLOOR) (o reaches beyond
    /// theta_g only above it: theta_o <= theta_i + 2 theta_h) and FINE_CEILING into equal panels of at most
    /// FINE_PANEL; returns (x0, x1), the refined range.
    fn refine(&self, breaks: &mut Vec<f64>, theta_g: f64) -> (f64, f64) {
        let x0 = (0.5 * (theta_g - self.i[0].atan2(self.i[2]))).max(FINE_FLOOR).tan().ln().max(breaks[0]);
        let x1 = FINE_CEILING.min(breaks[breaks.len() - 1]);
        let mut fine = vec![];
        for panel in breaks.windows(2).filter(|w| w[1] > x0 && w[0] < x1) {
            let (a, b) = (panel[0].max(x0), panel[1].min(x1));
            if b <= a {
                continue;
            }
            let n = ((b - a) / FINE_PANEL).ceil() as usize;
            fine.extend((0..=n).map(|k| a + (b - a) * k as f64 / n as f64));
        }
        breaks.extend(fine);
        breaks.sort_by(f64::total_cmp);
        breaks.dedup();
        (x0, x1)
    }
}

/// Calls f(pair, o, w) at every node of the fixed half-vector rule for incidence mu, w the weight
/// of rho(i, o) there (E = sum w rho); refined beyond theta_g (g = 1 below it) when given.
fn visit(brdf: &MaterialBrdf, mu: f64, theta_g: Option<f64>, mut f: impl FnMut(&Pair, [f64; 3], f64)) {
    let inc = Incidence::new(mu);
    let mut breaks = inc.breaks(brdf.beta, brdf.p);
    let (x0, x1) = theta_g.map_or((f64::INFINITY, f64::INFINITY), |t| inc.refine(&mut breaks, t));
    let (xs, xw) = composite_rule(&breaks, NODES);
    let rules = [gauss_legendre(PHI_NODES), gauss_legendre(FINE_PHI_NODES)];
    for (&x, &wx) in xs.iter().zip(&xw) {
        let (px, pw) = &rules[usize::from(x > x0 && x < x1)];
        let theta_h = x.exp().atan();
        let phi_max = inc.phi_max(theta_h);
        // dtheta_h = sin cos dx; dh = sin theta_h dtheta_h dphi; 2 for phi in [-phi_max, phi_max].
        let (st, ct) = theta_h.sin_cos();
        let w_theta = 2.0 * wx * st * ct * st * 0.5 * phi_max;
        for (&t, &wt) in px.iter().zip(pw) {
            let phi = 0.5 * phi_max * (t + 1.0);
            let Some((o, jacobian)) = inc.reflect(theta_h, phi) else { continue };
            let Some(pair) = brdf.pair(inc.i, o) else { continue };
            f(&pair, o, w_theta * wt * jacobian * o[2]);
        }
    }
}

/// The theta_i axis as a runtime reads it at a direction (sin, cos): cell and weight of node i + 1.
struct ThetaGrid {
    eps: f64,
    delta: f64,
    e0: f64,
    inv_step: f64,
    n: usize,
}

impl ThetaGrid {
    fn new(axis: &Axis) -> ThetaGrid {
        let AxisEncoding::BoundedLogTan { eps, delta } = axis.encoding else { unreachable!("theta_i's encoding") };
        let e = axis.encoded();
        ThetaGrid { eps, delta, e0: e[0], inv_step: (e.len() - 1) as f64 / (e[e.len() - 1] - e[0]), n: e.len() }
    }

    fn cell_at(&self, e: f64) -> (usize, f64) {
        let f = ((e - self.e0) * self.inv_step).clamp(0.0, (self.n - 1) as f64);
        let i = (f as usize).min(self.n - 2);
        (i, f - i as f64)
    }

    /// e = ln((sin + eps cos)/(cos + delta sin)) (epd_g1's form, finite at the horizon).
    fn cell(&self, sin: f64, cos: f64) -> (usize, f64) {
        self.cell_at(((sin + self.eps * cos) / (cos + self.delta * sin)).ln())
    }
}

/// What one incidence gives per wavelength: E of the paper's BRDF, E_s of its specular part and,
/// with the diffraction scale g of every theta_i node (g[node * nl + lambda]), D_g = int g(theta_o)
/// f_d_sym cos theta_o do, so that E_c = E_s + g(theta_i) D_g; `fresnel`: the same three with
/// F_eta(cos theta_d) in the integrand (a dielectric interface, docs/maths.md section 10).
#[derive(Clone, Copy, Default)]
struct Sums {
    e: f64,
    e_s: f64,
    d_g: f64,
    fresnel: [f64; 3],
}

/// E, E_s and D_g at mu for each of `lambdas` by the fixed half-vector rule, refined beyond theta_g
/// (D_g = 0 without `g`); with `ior`, also weighted by the dielectric's Fresnel factor.
fn albedo(
    brdf: &MaterialBrdf,
    mu: f64,
    lambdas: &[f64],
    g: Option<(&ThetaGrid, &[f32])>,
    theta_g: Option<f64>,
    ior: Option<f64>,
) -> Vec<Sums> {
    let waves = brdf.waves((1.0 - mu * mu).sqrt(), lambdas);
    let nl = lambdas.len();
    let mut sums = vec![Sums::default(); nl];
    let mut parts = WaveParts::default();
    visit(brdf, mu, theta_g, |pair, o, w| {
        let sin_o = o[0].hypot(o[1]);
        brdf.wave_parts(pair, sin_o, &waves, &mut parts);
        let cell = g.map(|(grid, _)| grid.cell(sin_o, o[2]));
        let w_f = ior.map(|eta| w * fresnel::dielectric(pair.cos_d, eta));
        for (k, sum) in sums.iter_mut().enumerate() {
            let (s, d, sym) = (parts.s[k], parts.d[k], parts.sym[k]);
            sum.e += w * (s + d);
            sum.e_s += w * s;
            let g_o = match (g, cell) {
                (Some((_, values)), Some((j, t))) => {
                    let g_o = (1.0 - t) * values[j * nl + k] as f64 + t * values[(j + 1) * nl + k] as f64;
                    sum.d_g += w * d * sym * g_o;
                    g_o
                }
                _ => 0.0,
            };
            if let Some(w_f) = w_f {
                sum.fresnel[0] += w_f * (s + d);
                sum.fresnel[1] += w_f * s;
                sum.fresnel[2] += w_f * d * sym * g_o;
            }
        }
    });
    sums
}

/// The reciprocal diffraction part's kernel at mu on the coarse theta grid, per wavelength:
/// kernel[lambda][j] = int f_d_sym(i, o) h_j(theta_o) cos theta_o do, h_j node j's hat function in the
/// encoded theta; and E_s per wavelength.
fn kernel(brdf: &MaterialBrdf, mu: f64, lambdas: &[f64], grid: &ThetaGrid) -> (Vec<f64>, Vec<Vec<f64>>) {
    let waves = brdf.waves((1.0 - mu * mu).sqrt(), lambdas);
    let mut e_s = vec![0.0; lambdas.len()];
    let mut rows = vec![vec![0.0; grid.n]; lambdas.len()];
    let mut parts = WaveParts::default();
    visit(brdf, mu, None, |pair, o, w| {
        let sin_o = o[0].hypot(o[1]);
        brdf.wave_parts(pair, sin_o, &waves, &mut parts);
        let (j, t) = grid.cell(sin_o, o[2]);
        for (k, (es, row)) in e_s.iter_mut().zip(rows.iter_mut()).enumerate() {
            *es += w * parts.s[k];
            row[j] += w * parts.d[k] * parts.sym[k] * (1.0 - t);
            row[j + 1] += w * parts.d[k] * parts.sym[k] * t;
        }
    });
    (e_s, rows)
}

/// g on the coarse nodes of one wavelength: the fixed point of g <- g sqrt((1 - E_s)/(E_c - E_s)) where
/// E_s + E_d > 1 (g = 1 elsewhere), E_c = E_s + g (K g), E_d = sum K: the reciprocal scale g_i g_o that
/// brings the albedo to 1 wherever it exceeds it.
fn balance(e_s: &[f64], kernel: &[&[f64]]) -> Vec<f64> {
    let n = e_s.len();
    let over: Vec<bool> = (0..n).map(|i| e_s[i] + kernel[i].iter().sum::<f64>() > 1.0).collect();
    let mut g = vec![1.0; n];
    for _ in 0..BALANCE_MAX {
        let next: Vec<f64> = (0..n)
            .map(|i| {
                if !over[i] {
                    return 1.0;
                }
                let d = g[i] * kernel[i].iter().zip(&g).map(|(k, g)| k * g).sum::<f64>();
                if d > 0.0 {
                    (g[i] * ((1.0 - e_s[i]).max(0.0) / d).sqrt()).min(1.0)
                } else {
                    1.0
                }
            })
            .collect();
        let moved = next.iter().zip(&g).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        g = next;
        if moved < BALANCE_TOL {
            break;
        }
    }
    g
}

/// F_eta(cos theta_d) of (i, o) for a dielectric of index `ior`, 1 without one.
fn fresnel_weight(ior: Option<f64>, i: [f64; 3], o: [f64; 3]) -> f64 {
    let Some(eta) = ior else { return 1.0 };
    let h = [i[0] + o[0], i[1] + o[1], i[2] + o[2]];
    let cos_d = (i[0] * h[0] + i[1] * h[1] + i[2] * h[2]) / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    fresnel::dielectric(cos_d.clamp(0.0, 1.0), eta)
}

/// E of the paper's BRDF at (mu, lambda) by `adaptive` (weighted by F_eta with `ior`).
pub fn albedo_adaptive(brdf: &MaterialBrdf, mu: f64, lambda: f64, ior: Option<f64>, tol: f64) -> f64 {
    let i = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    adaptive(mu, brdf.beta, brdf.p, tol, |o| {
        fresnel_weight(ior, i, o) * brdf.eval_parts(i, o, lambda).iter().sum::<f64>()
    })
}

/// E_c of the compensated single scattering, f_s + g(theta_i) g(theta_o) f_d_sym, at (theta_i, lambda) by
/// `adaptive`, g read as a runtime reads it: `column` holds g at the probe's lambda on every theta_i node
/// (`g_column`), linear in the encoded theta (`grid`) between them (weighted by F_eta with `ior`). Reading g
/// through those, not the general N-D `interpolate`, halved this reference's time (128 probes: 1.0-1.8 s -> 0.5-0.9 s
/// per material where g < 1).
fn compensated_adaptive(
    brdf: &MaterialBrdf,
    grid: &ThetaGrid,
    column: &[f64],
    (theta_i, lambda): (f64, f64),
    ior: Option<f64>,
    tol: f64,
) -> f64 {
    let (sin_i, mu) = theta_i.sin_cos();
    let i = [sin_i, 0.0, mu];
    let g_at = |sin: f64, cos: f64| {
        let (j, t) = grid.cell(sin, cos);
        (1.0 - t) * column[j] + t * column[j + 1]
    };
    let g_i = g_at(sin_i, mu);
    let bb = brdf.b / lambda;
    let ln_r_i = if brdf.has_diffraction() { brdf.ln_r(sin_i, bb) } else { 0.0 };
    adaptive(mu, brdf.beta, brdf.p, tol, |o| {
        let [s, d] = brdf.eval_parts(i, o, lambda);
        let f = fresnel_weight(ior, i, o);
        if d == 0.0 {
            return f * s;
        }
        let sin_o = o[0].hypot(o[1]);
        let sym = (0.5 * (ln_r_i - brdf.ln_r(sin_o, bb))).exp();
        f * (s + g_i * g_at(sin_o, o[2]) * d * sym)
    })
}

/// g (`values`, C order over `axes`) on every theta_i node at `lambda`, linear in the encoded lambda as a
/// runtime reads it.
fn g_column(axes: &[Axis], values: &[f32], lambda: f64) -> Vec<f64> {
    let Some(lambdas) = axes.get(1) else { return values.iter().map(|&g| g as f64).collect() };
    let (k, t) = lambdas.locate(lambda).expect("inside the lambda axis");
    values.chunks(lambdas.len()).map(|row| (1.0 - t) * row[k] as f64 + t * row[k + 1] as f64).collect()
}

/// The axes: theta_i (and lambda when the material diffracts).
pub fn axes(m: &Material) -> Vec<Axis> {
    let theta = Axis::uniform(
        "theta_i",
        AxisEncoding::BoundedLogTan { eps: EPS, delta: DELTA_BETA * m.beta },
        0.0,
        MU_MIN.acos(),
        THETA_NODES,
    );
    match m.wavelengths {
        Some((lo, hi)) if m.has_diffraction() => {
            // One wavelength: widened 1e-6 either side (an axis needs two distinct nodes).
            let (lo, hi) = if hi > lo { (lo, hi) } else { (lo * (1.0 - 1e-6), hi * (1.0 + 1e-6)) };
            let n = ((hi / lo).ln() * LAMBDA_NODES_PER_LN).ceil().max(8.0) as usize + 1;
            vec![theta, Axis::uniform("lambda", AxisEncoding::Log, lo, hi, n)]
        }
        _ => vec![theta],
    }
}

/// 2 int_0^1 E(mu) mu dmu = int E sin 2 theta dtheta of the stored E of one lambda column (linear
/// in the encoded theta between nodes, E(acos MU_MIN) beyond as a runtime clamps).
fn average(theta: &Axis, column: &[f32]) -> f64 {
    let tail = column[theta.len() - 1] as f64 * MU_MIN * MU_MIN;
    theta_average(theta, tail, |j, t| (1.0 - t) * column[j] as f64 + t * column[j + 1] as f64)
}

/// g on every theta_i node (g[node * nl + lambda]): balanced on every STRIDE-th node, linear in the
/// encoded theta_i between them; 1 without diffraction.
fn gains(brdf: &MaterialBrdf, theta: &Axis, lambdas: &[f64]) -> Vec<f32> {
    let nl = lambdas.len();
    if !brdf.has_diffraction() {
        return vec![1.0; theta.len() * nl];
    }
    let coarse_axis = Axis::uniform("theta_i", theta.encoding, 0.0, MU_MIN.acos(), (theta.len() - 1) / STRIDE + 1);
    let coarse = ThetaGrid::new(&coarse_axis);
    let rows: Vec<(Vec<f64>, Vec<Vec<f64>>)> =
        coarse_axis.nodes.par_iter().map(|&t| kernel(brdf, t.cos(), lambdas, &coarse)).collect();
    let balanced: Vec<Vec<f64>> = (0..nl)
        .map(|k| {
            let e_s: Vec<f64> = rows.iter().map(|r| r.0[k]).collect();
            let kernel: Vec<&[f64]> = rows.iter().map(|r| r.1[k].as_slice()).collect();
            balance(&e_s, &kernel)
        })
        .collect();
    let mut g = Vec::with_capacity(theta.len() * nl);
    for &e in theta.encoded() {
        let (j, t) = coarse.cell_at(e);
        g.extend(balanced.iter().map(|b| ((1.0 - t) * b[j] + t * b[j + 1]) as f32));
    }
    g
}

/// 2 int_0^1 E(mu) mu dmu of each lambda column of a value stored per (theta_i, lambda) node, at every node.
fn averages(theta: &Axis, values: &[f32], nl: usize) -> Vec<f32> {
    let avg: Vec<f32> = (0..nl)
        .map(|k| average(theta, &values.iter().skip(k).step_by(nl).copied().collect::<Vec<_>>()) as f32)
        .collect();
    (0..values.len()).map(|j| avg[j % nl]).collect()
}

/// The largest of `errors`, its median and the probe where it is: the accuracy of one value.
fn worst(errors: &[f64], axes: &[Axis], points: &[Vec<f64>]) -> (f64, f64, serde_json::Map<String, serde_json::Value>) {
    let (max, at) = errors.iter().enumerate().fold((0.0f64, 0), |b, (i, &e)| if e > b.0 { (e, i) } else { b });
    let coordinates = axes.iter().zip(&points[at]).map(|(a, x)| (a.name.clone(), json!(x))).collect();
    (max, median(errors), coordinates)
}

/// `albedo` of the material whose other tables are in `dir`: e and e_avg of the paper's BRDF; g, e_comp
/// and e_comp_avg of the compensated one (docs/maths.md section 9). With a dielectric interface also
/// `interface_albedo`: the same integrals weighted by F_eta (section 10), from the same pass.
pub fn tables(m: &Material, dir: &Path) -> Result<Vec<Built>> {
    let start = Instant::now();
    let brdf = MaterialBrdf::open(dir)?;
    let axes = axes(m);
    let lambdas: Vec<f64> = axes.get(1).map_or(vec![1.0], |a| a.nodes.clone());
    let nl = lambdas.len();
    let ior = m.ior();
    let g = gains(&brdf, &axes[0], &lambdas);
    let grid = ThetaGrid::new(&axes[0]);
    let scale = brdf.has_diffraction().then_some((&grid, g.as_slice()));
    // theta_g: the theta_i node before the first where g < 1 at any lambda (g = 1 below it).
    let theta_g = g.iter().position(|&g| g < 1.0).map(|k| axes[0].nodes[(k / nl).saturating_sub(1)]);
    let rows: Vec<Vec<Sums>> =
        axes[0].nodes.par_iter().map(|&theta| albedo(&brdf, theta.cos(), &lambdas, scale, theta_g, ior)).collect();
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    let sums = || rows.iter().flatten();
    let e: Vec<f32> = sums().map(|x| x.e as f32).collect();
    let e_comp: Vec<f32> = sums().zip(&g).map(|(x, &g)| (x.e_s + g as f64 * x.d_g) as f32).collect();
    let e_f: Vec<f32> = sums().map(|x| x.fresnel[0] as f32).collect();
    let e_fc: Vec<f32> = sums().zip(&g).map(|(x, &g)| (x.fresnel[1] + g as f64 * x.fresnel[2]) as f32).collect();
    let array = |v: Vec<f32>| ArrayD::from_shape_vec(IxDyn(&shape), v).expect("one per node");
    let average = |v: &[f32]| array(averages(&axes[0], v, nl));
    let (e_avg, e_comp_avg, e_f_avg, e_fc_avg) = (average(&e), average(&e_comp), average(&e_f), average(&e_fc));
    let over = e_comp.iter().fold(0.0f32, |m, &x| m.max(x));
    let (values, g, e_comp, e_f, e_fc) = (array(e), array(g), array(e_comp), array(e_f), array(e_fc));
    let compute_seconds = start.elapsed().as_secs_f64();

    // The lookup of a value at the probes against its adaptive reference.
    let points = random_points(&axes, PROBES, SEED);
    let errors = |table: &ArrayD<f32>, n: usize, reference: &(dyn Fn(&[f64]) -> f64 + Sync)| -> Vec<f64> {
        points[..n]
            .par_iter()
            .map(|pt| (interpolate(&axes, &table.view(), pt).expect("inside") - reference(pt)).abs())
            .collect()
    };
    let plain = |ior: Option<f64>| {
        let brdf = &brdf;
        move |pt: &[f64]| albedo_adaptive(brdf, pt[0].cos(), pt.get(1).copied().unwrap_or(1.0), ior, REFERENCE_TOL)
    };
    let compensated = |ior: Option<f64>| {
        let (brdf, axes, grid, g) = (&brdf, &axes, &grid, g.as_slice().expect("standard layout"));
        move |pt: &[f64]| {
            let lambda = pt.get(1).copied().unwrap_or(1.0);
            compensated_adaptive(brdf, grid, &g_column(axes, g, lambda), (pt[0], lambda), ior, REFERENCE_TOL)
        }
    };

    let start = Instant::now();
    let (max, median_e, worst_e) = worst(&errors(&values, PROBES, &plain(None)), &axes, &points);
    let (comp_max, comp_median, comp_worst) = worst(&errors(&e_comp, COMP_PROBES, &compensated(None)), &axes, &points);
    let accuracy = json!({
        "what": format!("e: absolute error of the lookup (linear in the encoded theta_i{}) at {PROBES} random points (half uniform in \
                         the encodings, half at cell centres) against E by nested adaptive Gauss-Kronrod (7-15) over (ln tan theta_h, \
                         phi) at relative tolerance {REFERENCE_TOL:e}, of the same BRDF (the material's tables, docs/runtimes.md eval); \
                         includes the f32 rounding. e_avg: 2 int_0^1 e(mu) mu dmu of the stored e (its interpolant, clamped beyond \
                         acos(mu_min)) by 8-point Gauss-Legendre per cell, exact to f64 for that interpolant",
                        if nl > 1 { " and lambda" } else { "" }),
        "probes": PROBES,
        "target": TARGET,
        "max": max,
        "median": median_e,
        "worst": worst_e,
        "e_comp": {
            "what": format!("e_comp: the same at the first {COMP_PROBES} points, against the compensated single scattering f_s + \
                     g(theta_i) g(theta_o) f_d_sym (g read from the table as a runtime reads it) by the same adaptive quadrature; \
                     e_comp_avg as e_avg"),
            "probes": COMP_PROBES,
            "max": comp_max,
            "median": comp_median,
            "worst": comp_worst,
            "largest_node_value": over,
        },
    });
    let settings = json!({
        "theta_nodes": THETA_NODES, "mu_min": MU_MIN,
        "lambda_nodes_per_ln": m.has_diffraction().then_some(LAMBDA_NODES_PER_LN),
        "rule": format!("{}; where g < 1 (theta_o > theta_g, the theta_i node before \
                         the first with g < 1), in e's and e_comp's pass, every panel split into panels of at most {FINE_PANEL}, and {FINE_PHI_NODES} phi nodes, from \
                         theta_h = max((theta_g - theta_i)/2, {FINE_FLOOR}) to ln tan theta_h = {FINE_CEILING}", rule_text(NODES, PHI_NODES)),
        "brdf": "docs/runtimes.md eval with F = 1, lobe exact: the material's epd_g1, kcorr_renorm and zh_lobe read by interpolation",
        "g": format!("balanced on every {STRIDE}th theta_i node (the kernel of f_d_sym over theta_o's hat functions on those nodes, by the \
                      same rule), g <- g sqrt((1 - E_s)/(E_c - E_s)) where E_s + E_d > 1 until no g moves by {BALANCE_TOL:e}; linear in the \
                      encoded theta_i between them; e_comp = E_s + g(theta_i) int g(theta_o) f_d_sym cos theta_o do at every node \
                      (the refined rule)"),
    });
    let accuracy_seconds = start.elapsed().as_secs_f64();
    let albedo_values =
        vec![("e", values), ("e_avg", e_avg), ("g", g.clone()), ("e_comp", e_comp), ("e_comp_avg", e_comp_avg)];
    let mut out = vec![built(
        m,
        "albedo",
        axes.clone(),
        albedo_values,
        accuracy,
        settings.clone(),
        compute_seconds,
        accuracy_seconds,
        Default::default(),
    )];
    let Some(eta) = ior else { return Ok(out) };

    let start = Instant::now();
    let (f_max, f_median, f_worst) = worst(&errors(&e_f, PROBES, &plain(ior)), &axes, &points);
    let (fc_max, fc_median, fc_worst) = worst(&errors(&e_fc, COMP_PROBES, &compensated(ior)), &axes, &points);
    let accuracy = json!({
        "what": format!("e_f: absolute error of the lookup at albedo's {PROBES} random points against the adaptive quadrature of albedo's \
                         accuracy, the integrand weighted by F_eta(cos theta_d); includes the f32 rounding. e_fc: the same at the first \
                         {COMP_PROBES} points against the compensated single scattering's quadrature so weighted. The averages as albedo's"),
        "probes": PROBES,
        "target": TARGET,
        "max": f_max,
        "median": f_median,
        "worst": f_worst,
        "e_fc": { "probes": COMP_PROBES, "max": fc_max, "median": fc_median, "worst": fc_worst },
    });
    let mut settings = settings;
    settings["fresnel"] = json!(format!(
        "F_eta(cos theta_d), the unpolarised reflectance of a smooth dielectric of index {eta} \
                                         (twoscale_tables::fresnel::dielectric), at each node of albedo's pass"
    ));
    let values = vec![("e_f", e_f), ("e_f_avg", e_f_avg), ("e_fc", e_fc), ("e_fc_avg", e_fc_avg)];
    // The pass is shared with albedo: its time is albedo's compute_seconds.
    out.push(built(
        m,
        "interface_albedo",
        axes,
        values,
        accuracy,
        settings,
        0.0,
        start.elapsed().as_secs_f64(),
        Default::default(),
    ));
    Ok(out)
}
