//! Where the time goes: for each stage, the unit of work it is bound by
//! (integrand evaluations, fit samples, GEMM flops), how many units the paper
//! table needs, what one unit costs measured alone and what it costs inside
//! the build (stage CPU time / units): equal costs mean nothing but the unit
//! work is left. Plus the wall time of whole presets, as `twoscale build
//! --force` runs them.

use super::zh::sharp_corner;
use super::{sample_nodes, timed, BenchOptions, SEED};
use anyhow::Result;
use ndarray::Array2;
use serde_json::{json, Value};
use std::hint::black_box;
use std::time::Instant;
use twoscale_generate::build::build_table;
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::progress::Progress;
use twoscale_generate::tables::epd::g1_axes;
use twoscale_generate::tables::epd_math::{g1_counted, lambda_integrand, LAMBDA_REL_TOL};
use twoscale_generate::tables::kcorr::axes as kcorr_axes;
use twoscale_generate::tables::kcorr_math::{renorm_counted, ring_integrand, REL_TOL};
use twoscale_generate::tables::zh::ZH_CONVOLUTION;
use twoscale_generate::tables::zh_fit::cost;
use twoscale_generate::tables::zh_grid::{grid as zh_grid, PAPER_DEGREE};
use twoscale_generate::tables::zh_math::samples;
use twoscale_generate::tables::{BuildOptions, Preset};
use twoscale_tables::axis::Axis;

/// One stage: `units` of work per paper table at `unit_ns` each (measured
/// alone at random arguments, 1 thread), and the stage's CPU time (1 thread).
struct Stage {
    table: &'static str,
    stage: &'static str,
    unit: &'static str,
    units: f64,
    unit_ns: f64,
    cpu_seconds: f64,
    note: String,
}

impl Stage {
    /// `in_build_ns_per_unit` near `alone_ns_per_unit` means the stage runs at the
    /// cost of its unit of work: nothing else (bookkeeping, memory) is left to remove.
    fn to_json(&self) -> Value {
        json!({
            "table": self.table,
            "stage": self.stage,
            "unit": self.unit,
            "units_per_paper_table": self.units,
            "alone_ns_per_unit": self.unit_ns,
            "in_build_ns_per_unit": self.cpu_seconds * 1e9 / self.units,
            "cpu_seconds_paper_table": self.cpu_seconds,
            "note": self.note,
        })
    }
}

/// Random argument sets per integrand, and calls timed.
const ARGS: usize = 4096;
const CALLS: usize = 1_000_000;

/// Mean wall nanoseconds of `f` over `n` calls (1 thread).
fn ns_per_call(n: usize, f: impl Fn(usize) -> f64) -> f64 {
    let start = Instant::now();
    let mut sink = 0.0;
    for i in 0..n {
        sink += f(i);
    }
    black_box(sink);
    start.elapsed().as_secs_f64() * 1e9 / n as f64
}

fn entries(axes: &[Axis]) -> f64 {
    axes.iter().map(Axis::len).product::<usize>() as f64
}

/// A pointwise table: evaluations per entry (mean over sampled nodes), the
/// per-entry time on 1 thread, and the integrand's cost alone.
fn quadrature_stage(
    table: &'static str,
    axes: &[Axis],
    n_nodes: usize,
    counted: impl Fn(&[f64]) -> (f64, usize) + Sync + Send,
    integrand_ns: f64,
) -> Stage {
    let nodes = sample_nodes(axes, n_nodes, SEED);
    let (evals, seconds) = timed(1, || nodes.iter().map(|(_, pt)| black_box(counted(pt)).1 as f64).sum::<f64>());
    let per_entry = evals / nodes.len() as f64;
    Stage {
        table,
        stage: "values",
        unit: "integrand evaluation",
        units: per_entry * entries(axes),
        unit_ns: integrand_ns,
        cpu_seconds: seconds / nodes.len() as f64 * entries(axes),
        note: format!(
            "{per_entry:.0} evaluations per entry on average ({} random nodes); the rest is the adaptive \
             quadrature's bookkeeping and the entries skipped by bounds",
            nodes.len()
        ),
    }
}

/// GEMM rate of this machine for (m x k) . (k x n), flops per second (1 thread).
fn gemm_rate(m: usize, k: usize, n: usize) -> f64 {
    let a = Array2::from_shape_fn((m, k), |(i, j)| ((i * 7 + j * 3) % 11) as f64 * 0.1);
    let b = Array2::from_shape_fn((k, n), |(i, j)| ((i * 5 + j) % 13) as f64 * 0.1);
    let (_, seconds) = timed(1, || black_box(a.dot(&b)));
    2.0 * (m * k * n) as f64 / seconds
}

fn stages(quick: bool) -> Vec<Stage> {
    let mut rng = SplitMix64::new(SEED);
    let mut out = Vec::new();

    // epd_g1: Lambda's integrand at random y, over the paper grid's range of mu.
    let paper = g1_axes(Preset::Paper);
    let args: Vec<[f64; 4]> = (0..ARGS)
        .map(|_| {
            let (y, mu, two_p) = (5.0 * rng.uniform(), 0.01 + 10.0 * rng.uniform(), 0.1 + 9.9 * rng.uniform());
            [y, mu, mu.powf(two_p), two_p]
        })
        .collect();
    let integrand = ns_per_call(CALLS, |i| {
        let [y, mu, t0, two_p] = args[i % ARGS];
        lambda_integrand(y, mu, t0, two_p)
    });
    out.push(quadrature_stage(
        "epd_g1",
        &paper,
        if quick { 1000 } else { 5000 },
        |pt| g1_counted(pt[0], pt[1], LAMBDA_REL_TOL),
        integrand,
    ));

    // kcorr_renorm: the ring's integrand at random psi, s, B, c.
    let paper = kcorr_axes(Preset::Paper);
    let args: Vec<[f64; 4]> = (0..ARGS)
        .map(|_| {
            [
                std::f64::consts::PI * rng.uniform(),
                rng.uniform(),
                0.1 + 1000.0 * rng.uniform(),
                1.01 + 100.0 * rng.uniform(),
            ]
        })
        .collect();
    let integrand = ns_per_call(CALLS, |i| {
        let [psi, s, b, c] = args[i % ARGS];
        ring_integrand(psi, s, b, c)
    });
    out.push(quadrature_stage(
        "kcorr_renorm",
        &paper,
        if quick { 1000 } else { 5000 },
        |pt| renorm_counted(pt[0], pt[1], pt[2], REL_TOL),
        integrand,
    ));

    // zh_convolution: a build on p >= 4.6 (3 of 25 p nodes), 1 thread.
    let grid = zh_grid(Preset::Paper);
    let n_paper = entries(&grid.axes);
    let options = BuildOptions {
        progress: Progress { quiet: true },
        force: true,
        scene: Some(sharp_corner()),
        ..BuildOptions::default()
    };
    let (built, _) = timed(1, || ZH_CONVOLUTION.build(Preset::Paper, &options).expect("zh profile build"));
    let scale = n_paper / built.table.values[0].1.len() as f64;
    let stage_cpu = |k: &str| built.stages[k].as_f64().unwrap_or(f64::NAN) * scale;
    let fits = &built.accuracy["fit_residual"];
    let evaluations = fits["mean_evaluations"].as_f64().unwrap_or(f64::NAN);
    let smp = samples();
    let (sin2, ones): (Vec<f64>, Vec<f64>) = smp.iter().map(|s| (s.0, 1.0)).unzip();
    let data: Vec<f64> = sin2.iter().map(|x| (1.0 + 0.3 * x).powf(-1.5)).collect();
    let pass = ns_per_call(20_000, |i| cost(1.0, 0.4 + 1e-9 * i as f64, &sin2, &ones, &data, 2.0));
    out.push(Stage {
        table: "zh_convolution",
        stage: "fits",
        unit: "fit sample (one ln, one exp, the Newton sums)",
        units: 2.0 * n_paper * evaluations * smp.len() as f64,
        unit_ns: pass / smp.len() as f64,
        cpu_seconds: stage_cpu("fits_cpu_seconds"),
        note: format!(
            "2 fits per node, {evaluations:.2} passes over the 1000 samples per fit ({:.2} Newton steps); \
             the rest is the step logic and the projected-gradient test",
            fits["mean_iterations"].as_f64().unwrap_or(f64::NAN)
        ),
    });
    // Synthesis: per (p, beta), (n_u n_c x L) . (L x 1000).
    let (n_uc, l) = (grid.axes[0].len() * grid.axes[1].len(), PAPER_DEGREE);
    let flops = 2.0 * (n_uc * l * 1000) as f64 * (grid.axes[2].len() * grid.axes[3].len()) as f64;
    let rate = gemm_rate(n_uc, l, 1000);
    out.push(Stage {
        table: "zh_convolution",
        stage: "synthesis",
        unit: "GEMM flop",
        units: flops,
        unit_ns: 1e9 / rate,
        cpu_seconds: stage_cpu("synthesis_cpu_seconds"),
        note: format!(
            "C_L for every (u, c) of a (p, beta) in one matrix product; this machine's GEMM rate {:.1} GFLOP/s",
            rate * 1e-9
        ),
    });
    out
}

/// Wall seconds of `twoscale build --force` for every table of a preset (2 threads), into a
/// temporary directory: the whole preset, and the albedo tables' share of it.
fn whole_preset(preset: Preset) -> Result<(f64, f64)> {
    let dir = tempfile::tempdir()?;
    let options = BuildOptions { progress: Progress { quiet: true }, force: true, ..BuildOptions::default() };
    let albedo = std::sync::Mutex::new(0.0);
    let (result, seconds) = timed(2, || {
        twoscale_generate::tables::of_preset(preset).try_for_each(|def| {
            let start = std::time::Instant::now();
            build_table(def, preset, dir.path(), &options)?;
            if def.stage == "epd-albedo" {
                *albedo.lock().expect("not poisoned") += start.elapsed().as_secs_f64();
            }
            Ok::<(), anyhow::Error>(())
        })
    });
    result?;
    let albedo = albedo.into_inner().expect("not poisoned");
    Ok((seconds, albedo))
}

/// The profile as JSON: stages, and whole-preset times (paper only with `quick`).
pub fn run(options: BenchOptions) -> Result<Value> {
    let stages = stages(options.quick);
    let presets: Vec<Preset> = if options.quick { vec![Preset::Paper] } else { Preset::ALL.to_vec() };
    let mut whole = serde_json::Map::new();
    for preset in presets {
        let (seconds, albedo) = whole_preset(preset)?;
        tracing::info!("bench: whole {preset} preset in {seconds:.1} s on 2 threads ({albedo:.1} s of it epd_albedo and epd_albedo_avg)");
        whole.insert(preset.name().to_string(), json!(seconds));
        if albedo > 0.0 {
            whole.insert(format!("{}_without_albedo", preset.name()), json!(seconds - albedo));
        }
    }
    Ok(json!({
        "machine": { "threads": 2, "cpus": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1) },
        "whole_preset_seconds_2_threads": whole,
        "targets": {
            "paper": "<= 30 s (goal 15 s)",
            "default": "<= 1/5 of 0.10.0's (about 11 min on a usual day, epd_albedo 10 of them), goal 1/10 (issue 39)",
            "default_without_albedo": "<= 60 s (set before 0.10.0 added epd_albedo and epd_albedo_avg)",
        },
        "stages": stages.iter().map(Stage::to_json).collect::<Vec<_>>(),
    }))
}

/// The profile as printed lines.
pub fn summary(profile: &Value) -> Vec<String> {
    let num = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mut lines: Vec<String> = profile["stages"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|s| {
            format!(
                "{} {}: {:.3e} x {}, {:.3} ns each in the build vs {:.3} ns alone; {:.2} s CPU",
                s["table"].as_str().unwrap_or(""),
                s["stage"].as_str().unwrap_or(""),
                num(&s["units_per_paper_table"]),
                s["unit"].as_str().unwrap_or(""),
                num(&s["in_build_ns_per_unit"]),
                num(&s["alone_ns_per_unit"]),
                num(&s["cpu_seconds_paper_table"]),
            )
        })
        .collect();
    for (preset, seconds) in profile["whole_preset_seconds_2_threads"].as_object().into_iter().flatten() {
        lines.push(format!("whole {preset} preset: {:.1} s on 2 threads", num(seconds)));
    }
    lines
}
