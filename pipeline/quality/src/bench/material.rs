//! Per-material tables in `twoscale bench`: for two materials (the nickel and
//! a narrow lobe), the size and build time of zh_lobe and zh_lobe_sampling
//! against zh_lobe's error after interpolation, over grid sizes, beside the
//! general 5-D zh_lobe (the default preset's grid) read at the same
//! material's points (not with --quick).

use super::{timed, BenchOptions, Panel, Row, TableBench};
use twoscale_generate::accuracy::random_points;
use twoscale_generate::material::lobe::{derivation, lobe_and_cdf, series, tables_sized, U_NODES, V_NODES, XI_NODES};
use twoscale_generate::material::{Material, Model};
use twoscale_generate::progress::Progress;
use twoscale_generate::tables::context::BuildContext;
use twoscale_generate::tables::zh_grid::DEFAULT_DEGREE;
use twoscale_generate::tables::zh_lobe::{grid, lobe_lookup, lobe_values, table_lobe, LobeJob, SIZES};
use twoscale_generate::tables::{Job, Units};
use twoscale_tables::axis::Axis;
use twoscale_tables::Lookup;

const MEASURE: &str = "99th percentile of the pointwise relative error after interpolation of C over (u, theta_h) at the \
                       material's (c, p, beta), where C >= 1e-4 of its maximum at that u, as the per-material zh_lobe's \
                       manifest measures it (250 random u times 8 angles, against the series from each u's own coefficients)";

/// Grid sizes (u, v_theta, xi) swept: about 1/4, 1/2 and 1 of the shipped table, and twice.
const SWEEP: [[usize; 3]; 4] = [[33, 257, 513], [65, 513, 1025], [U_NODES, V_NODES, XI_NODES], [257, 2049, 4097]];

fn materials() -> Vec<Material> {
    let m = |name: &str, beta: f64, p: f64, b: f64, c: f64, w: (f64, f64)| Material {
        name: name.into(),
        beta,
        p,
        sigma_s: 0.01,
        b: Some(b),
        c: Some(c),
        wavelengths: Some(w),
        model: Model::Conductor,
    };
    vec![m("nickel", 0.03, 0.9, 0.8, 2.3, (0.45, 0.65)), m("narrow_diffraction", 0.02, 2.0, 8.0, 2.0, (0.38, 0.78))]
}

/// The general zh_lobe (the default preset's grid), built whole on 1 and 2 threads.
fn general_table() -> (Lookup, f64, f64) {
    let job = LobeJob::on(grid(SIZES), DEFAULT_DEGREE);
    let run = || job.compute(Units::all(job.units()), Progress { quiet: true });
    let (_, seconds_1) = timed(1, run);
    let (part, seconds_2) = timed(2, run);
    (lobe_lookup(job.axes(), lobe_values(job.axes(), job.values(&part))), seconds_2, seconds_1)
}

/// The general table's row for a material: its p99 at the material's points.
fn general_row(m: &Material, (lobe, seconds_2, seconds_1): &(Lookup, f64, f64)) -> Row {
    let c = m.c.expect("diffracting");
    let p99 = p99_at_material(m, |u, theta| table_lobe(lobe, &[u, c, m.p, m.beta], theta));
    let entries = lobe.nodes();
    let stored = entries * lobe.value_names().len();
    Row {
        entries_timed: entries,
        entries_table: entries,
        seconds_2: *seconds_2,
        seconds_1: *seconds_1,
        interp_error: Some(p99),
        interp_points: 2000,
        megabytes: Some(stored as f64 * 4.0 / 1e6),
        note: format!(
            "{}: the default preset's 5-D table, read at the material's (c, p, beta); time: its whole build",
            m.name
        ),
        ..Row::new(
            "general zh_lobe (default preset, 5-D)",
            SIZES.iter().map(usize::to_string).collect::<Vec<_>>().join("x"),
            m.name.clone(),
            Panel::Interpolation,
        )
    }
}

/// p99 of |lobe(u, theta) - C| / C where C >= 1e-4 of its maximum at u, at 250 random u times 8 random angles.
fn p99_at_material(m: &Material, lobe: impl Fn(f64, f64) -> f64) -> f64 {
    let u_axis = twoscale_generate::material::lobe::u_axis(m, 129);
    let us: Vec<f64> = random_points(std::slice::from_ref(&u_axis), 250, 0xbe).into_iter().map(|p| p[0]).collect();
    let terms = series(&BuildContext::default(), m, &us).expect("converged");
    let d = derivation(m);
    let v = Axis::uniform("v", twoscale_tables::axis::AxisEncoding::Linear, 0.0, 1.0, 257);
    let mut errors = Vec::new();
    for (k, (&u, h)) in us.iter().zip(&terms).enumerate() {
        let probe: Vec<f64> = v.nodes.iter().map(|&x| d.inverse(x, &[u])).collect();
        let max = lobe_and_cdf(h, &probe).0.into_iter().fold(0.0, f64::max);
        let vs: Vec<f64> =
            random_points(std::slice::from_ref(&v), 8, 0xbe + 1 + k as u64).into_iter().map(|p| p[0]).collect();
        let thetas: Vec<f64> = vs.iter().map(|&x| d.inverse(x, &[u])).collect();
        for (theta, exact) in thetas.iter().zip(lobe_and_cdf(h, &thetas).0) {
            if exact >= 1e-4 * max {
                errors.push((lobe(u, *theta) - exact).abs() / exact);
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    errors[((errors.len() - 1) as f64 * 0.99).round() as usize]
}

pub fn bench(options: BenchOptions) -> TableBench {
    let sizes: &[[usize; 3]] = if options.quick { &SWEEP[..2] } else { &SWEEP };
    let bar = options.progress.bar("bench material tables", (materials().len() * (sizes.len() + 1)) as u64);
    let mut rows = Vec::new();
    // --quick leaves out the general table (two whole builds of 62 MB).
    let general = (!options.quick).then(general_table);
    for m in materials() {
        for &size in sizes {
            let build = || tables_sized(&BuildContext::default(), &m, size).expect("converged");
            let (_, seconds_1) = timed(1, build);
            let ((lobe, sampling), seconds_2) = timed(2, build);
            let bytes = (lobe.table.values[0].1.len() + sampling.table.values[0].1.len()) as f64 * 4.0;
            tracing::info!(
                "bench material tables: {} {size:?}: {seconds_2:.2} s on 2 threads, p99 {}",
                m.name,
                lobe.accuracy["p99"]
            );
            rows.push(Row {
                entries_timed: lobe.table.values[0].1.len(),
                entries_table: lobe.table.values[0].1.len(),
                seconds_2,
                seconds_1,
                interp_error: lobe.accuracy["p99"].as_f64(),
                interp_points: lobe.accuracy["samples"].as_u64().unwrap_or(0) as usize,
                megabytes: Some(bytes / 1e6),
                note: format!(
                    "zh_lobe max {:.3e}; zh_lobe_sampling |F(quantile) - xi| max {:.3e}; time and size: both tables (build and accuracy)",
                    lobe.accuracy["max"].as_f64().unwrap_or(f64::NAN),
                    sampling.accuracy["max"].as_f64().unwrap_or(f64::NAN)
                ),
                ..Row::new("per-material zh_lobe + zh_lobe_sampling (u x v_theta x xi)", size.iter().map(usize::to_string).collect::<Vec<_>>().join("x"), m.name.clone(), Panel::Interpolation)
            });
            bar.inc(1);
        }
        if let Some(general) = &general {
            rows.push(general_row(&m, general));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    TableBench {
        table: "material_tables",
        node_measure: "(not measured: the nodes are the series of zh_convolution's method)",
        interp_measure: MEASURE,
        rows,
    }
}
