//! `zh_lobe` in `twoscale bench`: grid size (table size and build time)
//! against the error after interpolation, beside the paper's representation
//! of the same lobe, the fitted K-correlation lobes of `zh_convolution`
//! (default preset), measured the same way at the same points; and where
//! the error of the shipped grid (`--quick`: the largest swept) comes from,
//! axis by axis.

use super::zh::sharp_corner;
use super::{timed, BenchOptions, Panel, Row, TableBench};
use twoscale_generate::accuracy::random_points;
use twoscale_generate::progress::Progress;
use twoscale_generate::tables::zh::ZH_CONVOLUTION;
use twoscale_generate::tables::zh_grid::DEFAULT_DEGREE;
use twoscale_generate::tables::zh_lobe::{
    fitted_lobe_errors, grid, lobe_errors, lobe_lookup, lobe_values, reference, table_lobe, LobeJob, LobeSummary, SIZES,
};
use twoscale_generate::tables::zh_math::ThetaRule;
use twoscale_generate::tables::{restrict, BuildOptions, Job, Preset, Units};
use twoscale_tables::axis::{Axis, AxisEncoding};

const MEASURE: &str = "99th percentile of the pointwise relative error after interpolation, over the (point, angle) \
                       samples where C >= 1e-4 of the point's maximum: random parameter points uniform in ln(1 + 4u^2), \
                       c, ln p and ln beta, each at the 1000 angles of docs/maths.md section 4, against the zonal-harmonic sum to \
                       degree 2000 from each point's own coefficients (as the zh_lobe manifest's accuracy)";

/// Grid sizes swept (u, c, p, beta, v_theta): each axis scaled by about
/// 1/2, 3/4, 1 (the shipped table) and 5/4.
const SWEEP: [[usize; 5]; 4] = [[9, 4, 21, 13, 61], [13, 6, 31, 17, 91], SIZES, [21, 10, 51, 29, 151]];

/// The error attribution: probes snapped to their nearest node on every
/// parameter axis but the one named (none: only the angle axis interpolates).
const ATTRIBUTION: [(Option<usize>, &str); 5] =
    [(None, "theta_h only"), (Some(0), "u"), (Some(1), "c"), (Some(2), "p"), (Some(3), "beta")];

/// Values stored per node: ln C and its four control variates.
const STORED: f64 = 5.0;

/// The bench's probe seed.
pub const PROBE_SEED: u64 = 0x5eed;

/// `count` probes uniform in ln(1 + 4u^2), c, ln p (p >= `p_min`) and ln beta
/// (the even-numbered points of `random_points`): no grid of the sweep is
/// favoured, and the measure does not move when the table's encodings do.
pub fn probes(p_min: f64, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut axes = grid(SIZES)[..4].to_vec();
    axes[2] = Axis::uniform("p", AxisEncoding::Log, p_min, 5.0, 2);
    random_points(&axes, 2 * count, seed).into_iter().step_by(2).collect()
}

/// `points` moved to their nearest node on every parameter axis but `free`.
pub fn snapped(points: &[Vec<f64>], axes: &[Axis], free: Option<usize>) -> Vec<Vec<f64>> {
    let snap = |d: usize, x: f64| {
        let (i, t) = axes[d].locate(x).expect("probe inside the grid");
        axes[d].nodes[i + usize::from(t > 0.5)]
    };
    points
        .iter()
        .map(|pt| pt.iter().enumerate().map(|(d, &x)| if Some(d) == free { x } else { snap(d, x) }).collect())
        .collect()
}

fn note(s: &LobeSummary, extra: &str) -> String {
    let sep = if extra.is_empty() { "" } else { "; " };
    format!("pointwise median {:.3e}, max {:.3e}; relative L2 max {:.3e}{sep}{extra}", s.median, s.max, s.l2_max)
}

pub fn bench(options: BenchOptions) -> TableBench {
    let quick = options.quick;
    let scene = quick.then(sharp_corner);
    let build_options = BuildOptions {
        progress: Progress { quiet: true },
        force: true,
        scene: scene.clone(),
        ..BuildOptions::default()
    };
    let grid_label = if quick { "default (p >= 4.6)" } else { "default" };
    let points = probes(if quick { 4.6 } else { 0.2 }, if quick { 60 } else { 400 }, PROBE_SEED);
    let rule = ThetaRule::standard(DEFAULT_DEGREE);
    let exact = reference(&points, &rule, DEFAULT_DEGREE);

    let sizes: &[[usize; 5]] = if quick { &SWEEP[..2] } else { &SWEEP };
    let bar = options.progress.bar("bench zh_lobe", sizes.len() as u64 + 2);
    let mut rows = Vec::new();
    let attributed_size = if sizes.contains(&SIZES) { SIZES } else { sizes[sizes.len() - 1] };
    let mut attributed = None;
    for &size in sizes {
        let full = grid(size);
        let entries_table: usize = full.iter().map(Axis::len).product();
        let (axes, _) = restrict(full, &build_options).expect("the sub-grid lies inside the default grid");
        let job = LobeJob::on(axes, DEFAULT_DEGREE);
        let run = || job.compute(Units::all(job.units()), Progress { quiet: true });
        let (_, seconds_1) = timed(1, run);
        let (part, seconds_2) = timed(2, run);
        let lobe = lobe_lookup(job.axes(), lobe_values(job.axes(), job.values(&part)));
        let errors = lobe_errors(&exact, |i, th| table_lobe(&lobe, &points[i], th)).summary();
        let entries_timed = lobe.nodes();
        let scale = entries_table as f64 / entries_timed as f64;
        tracing::info!("bench zh_lobe: {size:?}: {:.2} s on 2 threads, p99 {:.3e}", seconds_2, errors.p99);
        rows.push(Row {
            entries_timed,
            entries_table,
            seconds_2: seconds_2 * scale,
            seconds_1: seconds_1 * scale,
            interp_error: Some(errors.p99),
            interp_points: points.len(),
            megabytes: Some(entries_table as f64 * STORED * 4.0 / 1e6),
            note: note(&errors, if size == SIZES { "the shipped grid" } else { "" }),
            ..Row::new(
                "twoscale: zh_lobe grid size (u x c x p x beta x v_theta)",
                size.iter().map(usize::to_string).collect::<Vec<_>>().join("x"),
                grid_label.into(),
                Panel::Interpolation,
            )
        });
        bar.inc(1);
        if size == attributed_size {
            attributed = Some((job, lobe));
        }
    }

    // Where the shipped grid's error comes from: one parameter axis at a time
    // off-grid (and none), each against the reference at the moved probes. Rows without timing.
    let (job, lobe) = attributed.expect("the attributed grid is swept");
    let megabytes = Some(attributed_size.iter().product::<usize>() as f64 * STORED * 4.0 / 1e6);
    let diagnostic = |errors: &LobeSummary, probes: usize, what: &str, series: &'static str, setting: &str| Row {
        interp_error: Some(errors.p99),
        interp_points: probes,
        megabytes,
        note: note(errors, what),
        ..Row::new(series, setting.into(), grid_label.into(), Panel::Interpolation)
    };
    for (free, name) in ATTRIBUTION {
        let moved = snapped(&points, job.axes(), free);
        let exact = reference(&moved, &rule, DEFAULT_DEGREE);
        let errors = lobe_errors(&exact, |i, th| table_lobe(&lobe, &moved[i], th)).summary();
        rows.push(diagnostic(
            &errors,
            moved.len(),
            "the probes moved to their nearest node on the other parameter axes (no timing)",
            "attribution: the shipped grid (--quick: the largest) with one parameter axis off-grid",
            name,
        ));
    }
    bar.inc(1);

    // The fitted lobes: zh_convolution's default grid, its build timed the same way.
    let build = || ZH_CONVOLUTION.build(Preset::Default, &build_options).expect("zh_convolution build");
    let (one, two) = (timed(1, build).0, timed(2, build).0);
    let full_entries: usize =
        twoscale_generate::tables::zh_grid::grid(Preset::Default).axes.iter().map(Axis::len).product();
    let timed_entries = two.table.values[0].1.len();
    let scale = full_entries as f64 / timed_entries as f64;
    for (cos, name) in [(false, "plain (s, g)"), (true, "cos (s_cos, g_cos)")] {
        let errors = fitted_lobe_errors(&exact, &two.table.axes, &two.table.values, &points, cos).summary();
        rows.push(Row {
            entries_timed: timed_entries,
            entries_table: full_entries,
            seconds_2: two.compute_seconds * scale,
            seconds_1: one.compute_seconds * scale,
            interp_error: Some(errors.p99),
            interp_points: points.len(),
            // The two values (s, g) per node this lobe reads.
            megabytes: Some(full_entries as f64 * 2.0 * 4.0 / 1e6),
            note: note(&errors, "time: zh_convolution's whole build (coefficients, synthesis, both fits); size: its two values per node"),
            ..Row::new("paper: zh_convolution's fitted K-correlation lobe", name.into(), grid_label.into(), Panel::Interpolation)
        });
    }
    bar.inc(1);
    bar.finish_and_clear();
    TableBench {
        table: "zh_lobe",
        node_measure: "(not measured: zh_lobe's nodes are zh_convolution's C_L)",
        interp_measure: MEASURE,
        rows,
    }
}
