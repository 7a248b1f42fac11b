//! Stage `kcorr-renorm`: the K-correlation renormalisation table
//! `kcorr_renorm` = R(s, B, c) (docs/maths.md section 3).

use super::job::{Job, Units};
use super::kcorr_math::{renorm, renorm_row, renorm_tol, REL_TOL, ROW_NODES};
use super::nodewise::{Nodewise, Values};
use super::options::BuildOptions;
use super::preset::Preset;
use super::sub_domain::restrict;
use super::table_def::TableDef;
use crate::accuracy::measure;
use crate::progress::Progress;
use anyhow::Result;
use ndarray::{ArrayD, IxDyn};
use serde_json::{json, Value};
use twoscale_tables::axis::{Axis, AxisEncoding};

pub const KCORR_RENORM: TableDef = TableDef {
    name: "kcorr_renorm",
    stage: "kcorr-renorm",
    definition: "docs/maths.md section 3: r = R(s, B, c), the fraction of the normalised K-correlation PSD \
                 B^2 (c-1)/(2 pi) (1 + B^2 |g|^2)^(-(c+1)/2) inside the propagating disk |g - (s, 0)| <= 1; \
                 s = sin(theta_i), B = b / lambda",
    axes,
    diffraction: true,
    cubic: false,
    job,
    presets: &Preset::ALL,
};

/// Random off-grid probes for the interpolation error.
const PROBES: usize = 40_000;
pub const REFERENCE_REL_TOL: f64 = 1e-14;

/// The accuracy target of the default preset: 1e-3 relative for R >= 1e-3,
/// 1e-6 absolute below.
pub fn target(r: f64) -> f64 {
    (1e-3 * r).max(1e-6)
}

/// Default grid: encodings chosen from measured 1-D interpolation errors in
/// the target's units (worst ratio ~ C / n^2): s by the log of the gap to
/// grazing incidence (C ~ 1.3e4; R changes within 1/B of s = 1), B by
/// ln B + ln ln(1 + B^2) (C ~ 1.5e4; 4.2e4 with ln B), c by ln(c - 1)
/// (C ~ 1.1e4). Sizes from 200k-probe measurements of the worst target ratio:
/// 130 x 190 x 150 (14.8 MB) 0.95; 160 x 180 x 150 (17.3 MB) 0.94;
/// 120 x 190 x 140 (12.8 MB) 1.09; 125 x 140 x 125 (8.8 MB) 1.45.
pub const DEFAULT_N: [usize; 3] = [130, 190, 150];

/// Axes (s, b_over_lambda, c).
pub fn axes(preset: Preset) -> Vec<Axis> {
    match preset {
        Preset::Paper => vec![
            Axis::new("s", (0..100).map(|k| k as f64 / 100.0).collect(), AxisEncoding::Linear),
            Axis::new(
                "b_over_lambda",
                (0..100).map(|i| (100.0 - i as f64) / (0.1 * (i as f64 + 1.0))).collect(),
                AxisEncoding::ShiftedReciprocal { shift: 10.0 },
            ),
            Axis::new("c", (0..100).map(|j| 101.0 / (100.0 - j as f64)).collect(), AxisEncoding::Reciprocal),
        ],
        Preset::Default => default_axes(DEFAULT_N),
    }
}

/// The default preset's axes with `n` = (n_s, n_B, n_c) nodes (`twoscale bench` varies them).
pub fn default_axes(n: [usize; 3]) -> Vec<Axis> {
    vec![
        Axis::uniform("s", AxisEncoding::LogGap { end: 1.0, eps: 1e-4 }, 0.0, 1.0, n[0]),
        Axis::uniform("b_over_lambda", AxisEncoding::LogPlusLogLog1pSq, 0.1, 1000.0, n[1]),
        Axis::uniform("c", AxisEncoding::ShiftedLog { shift: 1.0 }, 1.01, 101.0, n[2]),
    ]
}

/// R at every (B, c) node of one s, by the table's rule.
fn row(s: f64, rest: &[Axis]) -> Vec<f64> {
    renorm_row(s, &rest[0].nodes, &rest[1].nodes)
}

/// The table's job over (s, B, c) axes: a row of (B, c) per s node, then the accuracy.
fn nodewise(preset: Preset, axes: Vec<Axis>) -> Nodewise {
    Nodewise {
        table: KCORR_RENORM.name,
        preset: preset.name(),
        axes,
        value: "r",
        values: Values::Row(row),
        measure: measure_r,
    }
}

/// R at every node of a preset's axes, rounded to f32, as a build computes it (the job's values, no accuracy).
pub fn compute(preset: Preset, progress: Progress) -> ArrayD<f32> {
    let job = nodewise(preset, axes(preset));
    let shape: Vec<usize> = job.axes.iter().map(Axis::len).collect();
    let values = job.compute(Units::all(job.units()), progress).values.remove(0).1;
    ArrayD::from_shape_vec(IxDyn(&shape), values).expect("one entry per node")
}

fn job(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let (axes, _) = restrict(axes(preset), options)?;
    Ok(Box::new(nodewise(preset, axes)))
}

fn measure_r(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    let accuracy = measure(
        axes,
        values,
        "stored f32 r (the table's rule, renorm_row) against R from the adaptive quadrature at relative \
         tolerance 1e-14, at every stride-th node (flat C order); includes the f32 rounding",
        |pt| renorm_tol(pt[0], pt[1], pt[2], REFERENCE_REL_TOL),
        |pt| renorm(pt[0], pt[1], pt[2]),
        PROBES,
        Some(target),
        json!({
            "target": "max_target_ratio = max |lookup - R| / max(1e-3 R, 1e-6): <= 1 meets 1e-3 relative \
                       (R >= 1e-3) and 1e-6 absolute (below)",
            "quadrature": "closed-form inner disk mass (expm1/log1p) plus the ring integral in the boundary \
                           angle psi by one composite Gauss-Legendre rule per s shared by every (B, c): \
                           panels from the arc (1 - s) and the largest B's PSD (1/1000) scales up by 4, \
                           20 nodes each; against the adaptive G7/K15 rule at 1e-11 (renorm), the same \
                           f32 at every node of both presets (5.7e-13 relative at most); tests check renorm \
                           against R(0, B, c), an independent 2-D quadrature, the B -> inf limits and a \
                           1e-14-tolerance evaluation, and the table's rule against renorm",
        }),
    );
    let settings = json!({
        "rel_tol": REL_TOL,
        "row_nodes": ROW_NODES,
        "reference_rel_tol": REFERENCE_REL_TOL,
        "probes": PROBES
    });
    (accuracy, settings)
}
