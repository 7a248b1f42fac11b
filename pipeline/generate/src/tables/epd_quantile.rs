//! `epd_quantile` (docs/maths.md section 1b): the quantile of the EPD's D(m) cos theta_m at beta = 1 over
//! (p, xi), with which a renderer samples the EPD at any (beta, p): the slope density is radial and scales
//! with beta, so tan theta_m = beta tan theta_1(p, xi).

use super::epd::g1_axes;
use super::epd_math::{epd_cdf_by_quadrature, epd_quantile};
use super::job::Job;
use super::nodewise::{Nodewise, Values};
use super::options::BuildOptions;
use super::preset::Preset;
use super::sub_domain::restrict;
use super::table_def::TableDef;
use crate::accuracy::{json_f64, random_points};
use anyhow::Result;
use ndarray::ArrayD;
use rayon::prelude::*;
use serde_json::{json, Value};
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::interp::interpolate;

pub const EPD_QUANTILE: TableDef = TableDef {
    name: "epd_quantile",
    stage: "epd-g1",
    definition: "docs/maths.md section 1b: theta = theta_1(p, xi), the quantile at xi of D(m) cos theta_m in theta_m at beta = 1 \
                 (CDF P(1/p, tan^(2p) theta)); at any beta, tan theta_m = beta tan theta_1",
    axes: quantile_axes,
    diffraction: false,
    cubic: false,
    job,
    presets: &[Preset::Default],
};

/// Nodes in ln p and in asin(sqrt(xi)) (the per-material epd_sampling's). Measured |F(theta(xi)) - xi| after
/// bilinear interpolation, p >= 0.2, the largest of 4,000 probes: 160 nodes in 1/p 3.1e-3 (few nodes at large
/// p); in ln p 256 nodes 4.9e-4, 512 1.2e-4, 600 8.8e-5 (the interpolation in p dominates: error ~ 1/n^2).
const N_P: usize = 600;
const N_XI: usize = 1025;
const PROBES: usize = 4000;
const SEED: u64 = 0x7175;
/// Below this p the EPD at beta = 1 puts its mass so close to grazing (theta_1 = pi/2 - 1/t, t up to 1e13
/// at p = 0.05) that float32 cannot hold it: the figures are reported for p >= P_FLOAT32 and overall.
const P_FLOAT32: f64 = 0.2;

/// Axes (p, xi); the p axis spans epd_g1's.
pub fn quantile_axes(_: Preset) -> Vec<Axis> {
    let p = g1_axes(Preset::Default).swap_remove(0);
    vec![
        Axis::uniform("p", AxisEncoding::Log, p.min(), p.max(), N_P),
        Axis::uniform("xi", AxisEncoding::AsinSqrt, 0.0, 1.0, N_XI),
    ]
}

fn job(preset: Preset, options: &BuildOptions) -> Result<Box<dyn Job>> {
    let (axes, _) = restrict(quantile_axes(preset), options)?;
    Ok(Box::new(Nodewise {
        table: EPD_QUANTILE.name,
        preset: preset.name(),
        axes,
        value: "theta",
        values: Values::Node(|pt| epd_quantile(pt[0], 1.0, pt[1])),
        measure,
    }))
}

/// |F(theta) - xi| at nodes and at random probes, F by quadrature (independent of the incomplete gamma the
/// table is built with): over p >= P_FLOAT32 and over the whole axis.
fn measure(axes: &[Axis], values: &ArrayD<f32>) -> (Value, Value) {
    let n_xi = axes[1].len();
    let stride = (values.len() / 2000).max(1);
    let nodes: Vec<(f64, f64, f64)> = (0..values.len())
        .step_by(stride)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|k| {
            let (p, xi) = (axes[0].nodes[k / n_xi], axes[1].nodes[k % n_xi]);
            let theta = values.as_slice().expect("C order")[k] as f64;
            (p, xi, (epd_cdf_by_quadrature(p, 1.0, theta) - xi).abs())
        })
        .collect();
    let probes: Vec<(f64, f64, f64)> = random_points(axes, PROBES, SEED)
        .into_par_iter()
        .map(|pt| {
            let theta = interpolate(axes, &values.view(), &pt).expect("inside");
            (pt[0], pt[1], (epd_cdf_by_quadrature(pt[0], 1.0, theta) - pt[1]).abs())
        })
        .collect();
    let accuracy = json!({
        "what": "|F(theta) - xi|, F the CDF of D(m) cos theta_m at beta = 1 by double-exponential quadrature of \
                 p / Gamma(1/p) exp(-y^p) over y in [0, tan^2 theta] (independent of the incomplete gamma the table is \
                 built with), theta the stored float32 value at nodes, the bilinear lookup at random probes (half uniform \
                 in the encoded coordinates, half at cell centres); the pdf a renderer uses is the density its \
                 interpolation realises, exactly, so this error costs variance, never bias",
        "target": 1e-4,
        "target_applies": format!("p >= {P_FLOAT32}"),
        "nodes": stats(&nodes, stride),
        "probes": stats(&probes, 0),
    });
    (accuracy, json!({ "nodes": [N_P, N_XI], "probes": PROBES, "seed": SEED, "p_float32": P_FLOAT32 }))
}

fn stats(errors: &[(f64, f64, f64)], stride: usize) -> Value {
    let summary = |keep: &dyn Fn(f64) -> bool| {
        let kept: Vec<&(f64, f64, f64)> = errors.iter().filter(|e| keep(e.0)).collect();
        let worst = kept.iter().copied().fold((0.0, 0.0, 0.0), |w, e| if e.2 > w.2 { *e } else { w });
        let mut sorted: Vec<f64> = kept.iter().map(|e| e.2).collect();
        sorted.sort_by(f64::total_cmp);
        json!({
            "count": kept.len(),
            "max": json_f64(worst.2),
            "median": json_f64(sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)),
            "worst": { "p": worst.0, "xi": worst.1 },
        })
    };
    let mut out = json!({
        format!("p_at_least_{P_FLOAT32}"): summary(&|p| p >= P_FLOAT32),
        "all": summary(&|_| true),
    });
    if stride > 0 {
        out["stride"] = json!(stride);
    }
    out
}
