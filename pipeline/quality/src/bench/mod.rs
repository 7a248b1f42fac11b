//! `twoscale bench`: run time against error, table by table.
//!
//! Every table is swept over the settings that trade time for error
//! (quadrature tolerance or zonal-harmonic degree on the paper grid, grid
//! size with the default encodings) and over a baseline that follows the
//! published generators' method (midpoint rules, compass search). Each row
//! records the time on 2 threads and on 1 thread, the error at nodes against
//! a high-precision reference and, where a whole table is built, the error
//! after interpolation at random off-grid points. Rows whose time was
//! measured on part of a table (baselines, `--quick`) are scaled to the
//! whole table by entries, and say so (`entries_timed` < `entries_table`).

pub mod albedo;
pub mod epd;
pub mod kcorr;
pub mod material;
pub mod pointwise;
pub mod profile;
pub mod zh;
pub mod zh_lobe;

use crate::plot::{scatter_panels, Marker, Scatter};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::progress::Progress;
use twoscale_tables::axis::Axis;
use twoscale_tables::table::write_bytes_atomic;

#[derive(Clone, Copy, Debug, Default)]
pub struct BenchOptions {
    /// Smaller sweeps and samples (under two minutes on 2 cores).
    pub quick: bool,
    pub progress: Progress,
}

/// The two views of time against error (one plot panel each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Panel {
    /// Error at the nodes against the reference: the quadrature / degree
    /// sweeps and the baselines on the paper grid.
    Node,
    /// Error after interpolation at random off-grid points: every row that
    /// built a whole table (and the grid-size sweeps, which only appear here).
    Interpolation,
}

/// One setting of one table.
#[derive(Clone, Debug)]
pub struct Row {
    pub series: &'static str,
    pub baseline: bool,
    pub setting: String,
    pub grid: String,
    pub entries_timed: usize,
    pub entries_table: usize,
    /// Seconds for the whole table (scaled by entries when fewer were timed);
    /// NaN in rows that time nothing (error attributions), which are then
    /// off the Pareto fronts.
    pub seconds_2: f64,
    pub seconds_1: f64,
    pub node_error: f64,
    pub node_points: usize,
    pub interp_error: Option<f64>,
    pub interp_points: usize,
    /// Megabytes of f32 values the row's table stores for what is measured
    /// (whole table), where the sweep is over sizes.
    pub megabytes: Option<f64>,
    /// Where the row's sweep belongs: `Node` rows appear in both panels
    /// (the second when they have an interpolation error), `Interpolation` rows only there.
    pub panel: Panel,
    pub note: String,
    /// On the Pareto front of each panel (no other row of the panel is both
    /// faster and more accurate), indexed by `Panel as usize`.
    pub pareto: [bool; 2],
}

impl Row {
    /// A row of `series` with nothing measured yet: callers fill in the rest
    /// with struct-update syntax.
    pub fn new(series: &'static str, setting: String, grid: String, panel: Panel) -> Row {
        Row {
            series,
            baseline: false,
            setting,
            grid,
            entries_timed: 0,
            entries_table: 0,
            seconds_2: f64::NAN,
            seconds_1: f64::NAN,
            node_error: f64::NAN,
            node_points: 0,
            interp_error: None,
            interp_points: 0,
            megabytes: None,
            panel,
            note: String::new(),
            pareto: [false; 2],
        }
    }

    /// Competes for the Pareto fronts: only rows that time something (an
    /// error attribution does not).
    pub fn contends(&self) -> bool {
        self.seconds_2.is_finite()
    }

    /// The error `panel` plots for this row, if the row appears there.
    pub fn error(&self, panel: Panel) -> Option<f64> {
        match panel {
            Panel::Node => (self.panel == Panel::Node).then_some(self.node_error),
            Panel::Interpolation => self.interp_error,
        }
    }
}

/// A table's sweep: rows and what their errors measure.
pub struct TableBench {
    pub table: &'static str,
    pub node_measure: &'static str,
    pub interp_measure: &'static str,
    pub rows: Vec<Row>,
}

/// Runs `f` on a pool of `threads` threads: its result and wall seconds.
/// Builds without a context (`BuildOptions::context`) start from cold.
pub fn timed<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> (T, f64) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    pool.install(|| {
        let start = Instant::now();
        let out = f();
        (out, start.elapsed().as_secs_f64())
    })
}

/// `f` timed on 1 thread and then on 2: (result of the 2-thread run, seconds on 2, seconds on 1).
pub fn timed_both<T: Send>(f: impl Fn() -> T + Sync) -> (T, f64, f64) {
    let (_, one) = timed(1, &f);
    let (out, two) = timed(2, &f);
    (out, two, one)
}

/// `count` random node indices of a grid (deterministic for `seed`), and their points.
pub fn sample_nodes(axes: &[Axis], count: usize, seed: u64) -> Vec<(Vec<usize>, Vec<f64>)> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|_| {
            let idx: Vec<usize> =
                axes.iter().map(|a| ((rng.uniform() * a.len() as f64) as usize).min(a.len() - 1)).collect();
            let pt = idx.iter().zip(axes).map(|(&i, a)| a.nodes[i]).collect();
            (idx, pt)
        })
        .collect()
}

/// Largest |value - reference| / scale(reference).
pub fn max_scaled_error(values: &[f64], references: &[f64], scale: fn(f64) -> f64) -> f64 {
    values.iter().zip(references).map(|(v, r)| (v - r).abs() / scale(*r)).fold(0.0, f64::max)
}

/// Seed of the bench's samples (fixed: runs are comparable).
pub const SEED: u64 = 0x6265_6e63_6873_6565;

/// Marks each panel's Pareto front: sorted by time, a row is on it when it
/// is more accurate than every faster row.
pub fn mark_pareto(rows: &mut [Row]) {
    for panel in [Panel::Node, Panel::Interpolation] {
        let error = |r: &Row| r.error(panel).filter(|e| e.is_finite() && r.contends());
        let mut order: Vec<(usize, f64)> =
            rows.iter().enumerate().filter_map(|(i, r)| error(r).map(|e| (i, e))).collect();
        order.sort_by(|a, b| rows[a.0].seconds_2.total_cmp(&rows[b.0].seconds_2).then(a.1.total_cmp(&b.1)));
        let mut best = f64::INFINITY;
        for (i, e) in order {
            rows[i].pareto[panel as usize] = e < best;
            best = best.min(e);
        }
    }
}

/// For each baseline row: the fastest twoscale row of the same panel at an
/// error no larger, and the speed ratio (2 threads; 1 thread).
pub fn speed_ratios(bench: &TableBench) -> Vec<String> {
    let ours: Vec<&Row> = bench.rows.iter().filter(|r| !r.baseline && r.panel == Panel::Node).collect();
    bench
        .rows
        .iter()
        .filter(|r| r.baseline)
        .map(|b| {
            let best = ours
                .iter()
                .filter(|o| o.node_error <= b.node_error)
                .min_by(|x, y| x.seconds_2.total_cmp(&y.seconds_2));
            match best {
                Some(o) => format!(
                    "{}: baseline {} ({:.3e} error, {:.1} s) vs twoscale {} ({:.3e}, {:.2} s): {} faster on 2 threads, {} on 1",
                    bench.table,
                    b.setting,
                    b.node_error,
                    b.seconds_2,
                    o.setting,
                    o.node_error,
                    o.seconds_2,
                    ratio(b.seconds_2 / o.seconds_2),
                    ratio(b.seconds_1 / o.seconds_1)
                ),
                None => format!(
                    "{}: baseline {} ({:.3e} error, {:.1} s): no twoscale setting measured reaches that error",
                    bench.table, b.setting, b.node_error, b.seconds_2
                ),
            }
        })
        .collect()
}

/// "12x", or "0.8x" below 10.
fn ratio(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.1}x")
    } else {
        format!("{r:.0}x")
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The rows as CSV (one header line; errors as defined by the table's measures).
pub fn to_csv(bench: &TableBench) -> String {
    let mut out = String::from(
        "table,series,baseline,setting,grid,entries_timed,entries_table,seconds_2_threads,seconds_1_thread,\
         node_error,node_points,interp_error,interp_points,megabytes,pareto_node,pareto_interp,node_error_measure,interp_error_measure,note\n",
    );
    for r in &bench.rows {
        let interp = r.interp_error.map(|e| format!("{e:.6e}")).unwrap_or_default();
        let megabytes = r.megabytes.map(|m| format!("{m:.3}")).unwrap_or_default();
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{:.6},{:.6},{:.6e},{},{},{},{},{},{},{},{},{}",
            bench.table,
            csv_field(r.series),
            r.baseline,
            csv_field(&r.setting),
            csv_field(&r.grid),
            r.entries_timed,
            r.entries_table,
            r.seconds_2,
            r.seconds_1,
            r.node_error,
            r.node_points,
            interp,
            r.interp_points,
            megabytes,
            r.pareto[0],
            r.pareto[1],
            csv_field(bench.node_measure),
            csv_field(bench.interp_measure),
            csv_field(&r.note),
        );
    }
    out
}

/// The rows of `panel` as markers: x its error, y what `y` reads.
fn markers(rows: &[Row], panel: Panel, y: impl Fn(&Row) -> Option<f64>) -> Vec<Marker> {
    rows.iter()
        .filter_map(|r| {
            let (x, y) = (r.error(panel)?, y(r).filter(|y| y.is_finite())?);
            Some(Marker {
                x,
                y,
                series: r.series,
                baseline: r.baseline,
                contender: r.contends(),
                label: r.setting.clone(),
            })
        })
        .collect()
}

/// The picture of a sweep: node error (or, for a sweep of sizes, table size)
/// and error after interpolation, against time.
fn picture(bench: &TableBench, path: &Path) -> Result<()> {
    let seconds = "seconds, 2 threads (whole table)".to_string();
    let interp = "error after interpolation at random points";
    let nodes = markers(&bench.rows, Panel::Node, |r| Some(r.seconds_2));
    let nodes_panel = !nodes.is_empty() || bench.rows.iter().all(|r| r.megabytes.is_none());
    let left = if !nodes_panel {
        Scatter {
            title: "table size".into(),
            x_label: interp.into(),
            y_label: "MB stored (f32, whole table)".into(),
            markers: markers(&bench.rows, Panel::Interpolation, |r| r.megabytes),
        }
    } else {
        Scatter {
            title: "settings and baselines (error at the nodes)".into(),
            x_label: "error at the nodes (see CSV for the measure)".into(),
            y_label: seconds.clone(),
            markers: nodes,
        }
    };
    let right = Scatter {
        title: "every whole table built".into(),
        x_label: interp.into(),
        y_label: seconds,
        markers: markers(&bench.rows, Panel::Interpolation, |r| Some(r.seconds_2)),
    };
    let what = if nodes_panel { "run time" } else { "table size and run time" };
    scatter_panels(&format!("{}: {what} against error", bench.table), &[left, right], path)
}

/// The sweeps, by table.
const SWEEPS: [(&str, fn(BenchOptions) -> TableBench); 6] = [
    ("epd_g1", epd::bench),
    ("epd_albedo", albedo::bench),
    ("kcorr_renorm", kcorr::bench),
    ("zh_convolution", zh::bench),
    ("zh_lobe", zh_lobe::bench),
    ("material_tables", material::bench),
];

/// Runs the sweeps of `tables` (every table if empty), writing DIR/<table>.csv
/// and DIR/<table>.png, then, for every table, the profile (DIR/profile.json);
/// returns the sweeps and the profile.
pub fn run(
    options: BenchOptions,
    out: &Path,
    tables: &[String],
) -> Result<(Vec<TableBench>, Option<serde_json::Value>)> {
    if let Some(unknown) = tables.iter().find(|t| !SWEEPS.iter().any(|(name, _)| name == t)) {
        let names: Vec<&str> = SWEEPS.iter().map(|(name, _)| *name).collect();
        anyhow::bail!("no bench sweep for table {unknown:?} (sweeps: {})", names.join(", "));
    }
    std::fs::create_dir_all(out).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
    let mut done = Vec::new();
    for (_, sweep) in SWEEPS.iter().filter(|(name, _)| tables.is_empty() || tables.iter().any(|t| t == name)) {
        let mut bench = sweep(options);
        mark_pareto(&mut bench.rows);
        write_bytes_atomic(&out.join(format!("{}.csv", bench.table)), to_csv(&bench).as_bytes())?;
        picture(&bench, &out.join(format!("{}.png", bench.table)))?;
        for line in speed_ratios(&bench) {
            tracing::info!("{line}");
        }
        done.push(bench);
    }
    if !tables.is_empty() {
        return Ok((done, None));
    }
    let profile = profile::run(options)?;
    write_bytes_atomic(&out.join("profile.json"), serde_json::to_string_pretty(&profile)?.as_bytes())?;
    Ok((done, Some(profile)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(seconds: f64, error: f64, baseline: bool) -> Row {
        Row {
            baseline,
            seconds_2: seconds,
            seconds_1: 2.0 * seconds,
            node_error: error,
            ..Row::new("s", format!("{seconds}"), String::new(), Panel::Node)
        }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_rows() {
        let mut rows = vec![row(1.0, 1e-3, false), row(2.0, 1e-2, false), row(3.0, 1e-5, false), row(0.5, 1e-1, true)];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto[Panel::Node as usize]).collect();
        assert_eq!(front, vec![true, false, true, true]);
        // A row with an interpolation error competes in the second panel too, alone here.
        assert_eq!(rows.iter().map(|r| r.pareto[Panel::Interpolation as usize]).collect::<Vec<_>>(), vec![false; 4]);
        rows[1].interp_error = Some(0.5);
        mark_pareto(&mut rows);
        assert!(rows[1].pareto[Panel::Interpolation as usize] && !rows[1].pareto[Panel::Node as usize]);
        // A row that times nothing does not compete, however small its error.
        rows.push(Row {
            interp_error: Some(1e-9),
            ..Row::new("attribution", String::new(), String::new(), Panel::Interpolation)
        });
        mark_pareto(&mut rows);
        assert!(rows[1].pareto[Panel::Interpolation as usize] && !rows[4].pareto[Panel::Interpolation as usize]);
    }

    #[test]
    fn speed_ratio_uses_the_fastest_row_at_no_larger_error() {
        let bench = TableBench {
            table: "t",
            node_measure: "",
            interp_measure: "",
            rows: vec![
                row(1.0, 1e-3, false),
                row(0.1, 1e-2, false),
                row(3.0, 1e-6, false),
                row(50.0, 2e-3, true),
                row(9.0, 1e-9, true),
            ],
        };
        let lines = speed_ratios(&bench);
        assert!(lines[0].contains("50x faster on 2 threads, 50x on 1"), "{}", lines[0]);
        assert!(lines[1].contains("no twoscale setting"), "{}", lines[1]);
    }

    #[test]
    fn csv_quotes_fields_with_commas() {
        let bench =
            TableBench { table: "t", node_measure: "a, b", interp_measure: "", rows: vec![row(1.0, 1e-3, false)] };
        let csv = to_csv(&bench);
        assert_eq!(csv.lines().count(), 2);
        assert!(csv.lines().nth(1).unwrap().contains("\"a, b\""));
    }
}
