//! `twoscale plot TABLE`: a slice of a built table (two axes varying, the
//! others at their middle node) as heat maps, beside the error a renderer
//! sees there: multilinear interpolation at the centres of the slice's cells
//! against a direct evaluation (what `lookup` returns against the exact value).

use crate::plot::{heat_maps, line_pair, node_edges, short, HeatMap};
use anyhow::{bail, Context, Result};
use ndarray::{Array2, ArrayD};
use rayon::prelude::*;
use std::path::Path;
use twoscale_generate::tables::epd_albedo_column::albedo_column;
use twoscale_generate::tables::epd_math::{g1, norm};
use twoscale_generate::tables::kcorr_math::renorm;
use twoscale_generate::tables::lambda_table::LambdaTable;
use twoscale_generate::tables::zh_grid::{grid, PAPER_BETA_MAX};
use twoscale_generate::tables::zh_math::{coefficients, d_lobe, s_lobe, synthesis_matrix, ThetaRule};
use twoscale_generate::tables::Preset;
use twoscale_tables::axis::Axis;
use twoscale_tables::file::open_table;
use twoscale_tables::interp::interpolate;
use twoscale_tables::Lookup;

/// Cells shown per axis at most (a stride over the grid's cells beyond that).
const MAX_CELLS: usize = 240;

/// The slice: which axes vary (x, y), and the node index of every axis held fixed.
struct Slice {
    x: usize,
    y: usize,
    fixed: Vec<usize>,
}

impl Slice {
    fn new(axes: &[Axis], x: usize, y: usize) -> Slice {
        Slice { x, y, fixed: axes.iter().map(|a| a.len() / 2).collect() }
    }

    /// Where the fixed axes sit, for titles.
    fn describe(&self, axes: &[Axis]) -> String {
        let fixed: Vec<String> = (0..axes.len())
            .filter(|&d| d != self.x && d != self.y)
            .map(|d| format!("{} = {}", axes[d].name, short(axes[d].nodes[self.fixed[d]])))
            .collect();
        fixed.join(", ")
    }

    /// Node indices shown along axis d (a stride when there are too many).
    fn shown(axes: &[Axis], d: usize) -> Vec<usize> {
        let n = axes[d].len();
        let stride = n.div_ceil(MAX_CELLS).max(1);
        let mut v: Vec<usize> = (0..n).step_by(stride).collect();
        if *v.last().expect("non-empty axis") != n - 1 {
            v.push(n - 1);
        }
        v
    }

    /// The point at node indices (i along x, j along y).
    fn node(&self, axes: &[Axis], i: usize, j: usize) -> Vec<f64> {
        (0..axes.len())
            .map(|d| {
                axes[d].nodes[if d == self.x {
                    i
                } else if d == self.y {
                    j
                } else {
                    self.fixed[d]
                }]
            })
            .collect()
    }

    /// The point at the centre (in the encoding) of the cell between nodes a..b along x and c..d along y.
    fn centre(&self, axes: &[Axis], (a, b): (usize, usize), (c, d): (usize, usize)) -> Vec<f64> {
        let mid = |axis: &Axis, i: usize, k: usize| {
            let e = axis.encoded();
            axis.encoding.decode(0.5 * (e[i] + e[k])).clamp(axis.min(), axis.max())
        };
        let mut pt = self.node(axes, a, c);
        pt[self.x] = mid(&axes[self.x], a, b);
        pt[self.y] = mid(&axes[self.y], c, d);
        pt
    }
}

/// Heat map of `values` at the shown nodes.
fn value_map<'a>(title: String, axes: &'a [Axis], s: &Slice, values: &ArrayD<f32>) -> HeatMap<'a> {
    let (xs, ys) = (Slice::shown(axes, s.x), Slice::shown(axes, s.y));
    let sub = |a: &Axis, idx: &[usize]| Axis::new(&a.name, idx.iter().map(|&i| a.nodes[i]).collect(), a.encoding);
    let x_edges = node_edges(&sub(&axes[s.x], &xs));
    let y_edges = node_edges(&sub(&axes[s.y], &ys));
    let grid: Vec<Vec<f64>> = ys
        .iter()
        .map(|&j| {
            xs.iter()
                .map(|&i| {
                    let idx: Vec<usize> = (0..axes.len())
                        .map(|d| {
                            if d == s.x {
                                i
                            } else if d == s.y {
                                j
                            } else {
                                s.fixed[d]
                            }
                        })
                        .collect();
                    values[idx.as_slice()] as f64
                })
                .collect()
        })
        .collect();
    HeatMap { title, x: &axes[s.x], y: &axes[s.y], x_edges, y_edges, values: grid, log: false }
}

/// Heat map of `error(centre)` over the shown cells (blocks of cells when
/// strided, coloured by their first cell), and its maximum.
fn error_map<'a>(title: &str, axes: &'a [Axis], s: &Slice, error: impl Fn(&[f64]) -> f64 + Sync) -> (HeatMap<'a>, f64) {
    let (xs, ys) = (Slice::shown(axes, s.x), Slice::shown(axes, s.y));
    let cells: Vec<(usize, usize)> = (0..ys.len() - 1).flat_map(|j| (0..xs.len() - 1).map(move |i| (i, j))).collect();
    let errs: Vec<f64> = cells
        .par_iter()
        // The centre of the block's first grid cell: a real cell centre, where interpolation errs most.
        .map(|&(i, j)| error(&s.centre(axes, (xs[i], xs[i] + 1), (ys[j], ys[j] + 1))))
        .collect();
    let worst = errs.iter().copied().fold(0.0, f64::max);
    let values = errs.chunks(xs.len() - 1).map(<[f64]>::to_vec).collect();
    let edges = |d: usize, idx: &[usize]| idx.iter().map(|&i| axes[d].encoded()[i]).collect();
    let map = HeatMap {
        title: format!("{title} (max {worst:.2e})"),
        x: &axes[s.x],
        y: &axes[s.y],
        x_edges: edges(s.x, &xs),
        y_edges: edges(s.y, &ys),
        values,
        log: true,
    };
    (map, worst)
}

/// Interpolated `values` at a point (inside the table by construction).
fn lookup(axes: &[Axis], values: &ArrayD<f32>, pt: &[f64]) -> f64 {
    interpolate(axes, &values.view(), pt).expect("cell centres lie inside the table")
}

/// Draws the picture of `table` from `dir` (a preset directory) into `out`;
/// returns a one-line summary with the worst error shown.
pub fn plot_table(dir: &Path, table: &str, out: &Path) -> Result<String> {
    let (manifest, axes, values) = open_table(dir, table)?;
    let title = format!("{table} ({}, {})", manifest.preset, dir.display());
    let value = |name: &str| -> Result<&ArrayD<f32>> {
        values.iter().find(|(n, _)| n == name).map(|(_, v)| v).with_context(|| format!("{table} has no value {name:?}"))
    };
    if let Some(section) = &manifest.material {
        return plot_material(
            &title,
            &twoscale_generate::material::Material::from_section(section)?,
            table,
            &axes,
            &values,
            out,
        );
    }
    match table {
        "epd_norm" => {
            let n = value("n")?;
            let axis = &axes[0];
            let e = axis.encoded();
            let centres: Vec<(f64, f64)> = e
                .windows(2)
                .map(|w| {
                    let p = axis.encoding.decode(0.5 * (w[0] + w[1]));
                    (0.5 * (w[0] + w[1]), (lookup(&axes, n, &[p]) - norm(p)).abs() / norm(p).max(1e-300))
                })
                .collect();
            let worst = centres.iter().map(|c| c.1).fold(0.0, f64::max);
            let nodes: Vec<f64> = n.iter().map(|&v| v as f64).collect();
            line_pair(
                &format!("{title}: N(p) and its relative error at cell centres"),
                axis,
                &nodes,
                &centres,
                "|lookup - N| / N",
                out,
            )?;
            Ok(format!("{table}: worst relative error at cell centres {worst:.2e}"))
        }
        "epd_g1" => {
            let g = value("g1")?;
            let s = Slice::new(&axes, 1, 0);
            let (err, worst) = error_map("|lookup - G1| at cell centres", &axes, &s, |pt| {
                (lookup(&axes, g, pt) - g1(pt[0], pt[1])).abs()
            });
            heat_maps(&title, &[value_map("G1(p, a)".into(), &axes, &s, g), err], out)?;
            Ok(format!("{table}: worst |lookup - G1| at the cell centres shown {worst:.2e}"))
        }
        "kcorr_renorm" => {
            let r = value("r")?;
            let s = Slice::new(&axes, 1, 0);
            let (err, worst) = error_map("|lookup - R| / max(R, 1e-3) at cell centres", &axes, &s, |pt| {
                let exact = renorm(pt[0], pt[1], pt[2]);
                (lookup(&axes, r, pt) - exact).abs() / exact.max(1e-3)
            });
            let maps = [value_map(format!("R(s, B) at {}", s.describe(&axes)), &axes, &s, r), err];
            heat_maps(&title, &maps, out)?;
            Ok(format!(
                "{table}: worst |lookup - R| / max(R, 1e-3) at the cell centres shown {worst:.2e} ({})",
                s.describe(&axes)
            ))
        }
        "zh_convolution" => plot_zh(&title, &manifest.settings, &axes, (value("s")?, value("g")?), out),
        "zh_lobe" => {
            let ln_c = value("c_lobe")?;
            let lobe = Lookup::new(
                manifest.table.clone(),
                axes.clone(),
                values.clone(),
                manifest.derived_axes.clone(),
                manifest.value_encoding.clone(),
                manifest.interpolation,
            );
            plot_zh_lobe(&title, &manifest.settings, &lobe, ln_c, out)
        }
        "epd_albedo" => {
            // Over (theta_i, beta) at the p node nearest 1 (Beckmann): E, and |lookup - E| at the cell centres against the table's rule.
            let e = value("e")?;
            let mut s = Slice::new(&axes, 2, 1);
            s.fixed[0] = (0..axes[0].len())
                .min_by(|&i, &j| (axes[0].nodes[i] - 1.0).abs().total_cmp(&(axes[0].nodes[j] - 1.0).abs()))
                .expect("nodes");
            let p = axes[0].nodes[s.fixed[0]];
            let lambda = LambdaTable::new(p);
            let cubic = Lookup::new(
                manifest.table.clone(),
                axes.clone(),
                values.clone(),
                vec![],
                vec![],
                manifest.interpolation,
            );
            let (err, worst) = error_map("|lookup - E| at cell centres", &axes, &s, |pt| {
                (cubic.decode(pt).expect("inside")[0] - albedo_column(&lambda, pt[1], &[pt[2]])[0]).abs()
            });
            heat_maps(
                &title,
                &[value_map(format!("E(theta_i, beta) at {}", s.describe(&axes)), &axes, &s, e), err],
                out,
            )?;
            Ok(format!("{table}: worst |lookup - E| at the cell centres shown {worst:.2e} ({})", s.describe(&axes)))
        }
        "epd_albedo_avg" => {
            // E_avg over (beta, p); its error after interpolation is in the manifest (a reference costs ~0.3 s).
            let e = value("e_avg")?;
            let s = Slice::new(&axes, 1, 0);
            heat_maps(&title, &[value_map("E_avg(p, beta)".into(), &axes, &s, e)], out)?;
            let range = e.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            Ok(format!(
                "{table}: E_avg from {:.4} to {:.4} (error after interpolation: the manifest's accuracy)",
                range.0, range.1
            ))
        }
        _ => bail!("no picture defined for table {table:?}"),
    }
}

/// zh_lobe: stored ln C over (v_theta, p) at the middle u, c and beta, and
/// the pointwise relative error of the lookup at the cell centres against the
/// zonal-harmonic sum (the table's degree) from the point's own coefficients,
/// relative to max(C, 1e-4 max C) (the accuracy measurement's threshold).
fn plot_zh_lobe(
    title: &str,
    settings: &serde_json::Value,
    lobe: &Lookup,
    ln_c: &ArrayD<f32>,
    out: &Path,
) -> Result<String> {
    let axes = &lobe.axes;
    use twoscale_generate::numerics::legendre::legendre_all;
    use twoscale_generate::tables::zh_grid::{d_coefficients, s_coefficients};
    use twoscale_generate::tables::zh_lobe::{table_lobe, DERIVATION};
    let slice = Slice::new(axes, 4, 2);
    let (u, c, beta) = (axes[0].nodes[slice.fixed[0]], axes[1].nodes[slice.fixed[1]], axes[3].nodes[slice.fixed[3]]);
    let degree = settings["degree"].as_u64().context("manifest has no settings.degree")? as usize;
    // Every p at which cells are shown (cell centres), with its coefficient products and max C.
    let e = axes[2].encoded();
    let ps: Vec<f64> = e.windows(2).map(|w| axes[2].encoding.decode(0.5 * (w[0] + w[1]))).collect();
    let rule = ThetaRule::standard(degree);
    let w = rule.weighted_legendre(degree);
    let f = s_coefficients(&rule, &w, &[(u, c)]);
    let g = d_coefficients(&rule, &w, &ps.iter().map(|&p| (p, beta)).collect::<Vec<_>>());
    // max C over the 1000 angles of docs/maths.md section 4, per p: (F_l G_l)_l . Q.
    let max_c: Vec<f64> = (&g * &f.row(0))
        .dot(&synthesis_matrix(degree))
        .rows()
        .into_iter()
        .map(|r| r.iter().fold(0.0f64, |m, x| m.max(*x)))
        .collect();
    let error = |pt: &[f64]| {
        let i = (0..ps.len()).min_by(|&a, &b| (ps[a] - pt[2]).abs().total_cmp(&(ps[b] - pt[2]).abs())).expect("cells");
        let theta = DERIVATION.inverse(pt[4], &[pt[0], pt[2], pt[3]]);
        let mut leg = vec![0.0; degree];
        legendre_all((std::f64::consts::FRAC_PI_2 - theta).sin(), &mut leg);
        let exact: f64 =
            (0..degree).map(|l| std::f64::consts::PI * (2 * l + 1) as f64 * f[[0, l]] * g[[i, l]] * leg[l]).sum();
        (table_lobe(lobe, &pt[..4], theta) - exact).abs() / exact.max(1e-4 * max_c[i])
    };
    let at = slice.describe(axes);
    let (err, worst) = error_map("|lookup - C| / max(C, 1e-4 max C) at cell centres", axes, &slice, error);
    heat_maps(title, &[value_map(format!("ln C at {at}"), axes, &slice, ln_c), err], out)?;
    Ok(format!("zh_lobe: worst pointwise relative error of the lookup against C_L {worst:.2e} ({at})"))
}

/// zh_convolution: s and g over (u, c) at the middle p and beta, and the
/// relative L2 error of the plain lobe from interpolated (s, g) against the
/// zonal-harmonic sum C_L (the table's degree) at the cell centres.
fn plot_zh(
    title: &str,
    settings: &serde_json::Value,
    axes: &[Axis],
    (ln_s_vals, g_vals): (&ArrayD<f32>, &ArrayD<f32>),
    out: &Path,
) -> Result<String> {
    let slice = Slice::new(axes, 0, 1);
    let p = axes[2].nodes[slice.fixed[2]];
    let b = axes[3].nodes[slice.fixed[3]];
    let beta = if axes[3].name == "beta_over_beta_max" {
        let paper = grid(Preset::Paper);
        let k = paper.axes[2].nodes.iter().position(|&q| q == p).context("p is not a node of the paper grid")?;
        b * PAPER_BETA_MAX[k]
    } else {
        b
    };
    let degree = settings["degree"].as_u64().context("manifest has no settings.degree")? as usize;
    let rule = ThetaRule::standard(degree);
    let w = rule.weighted_legendre(degree);
    let g_row = coefficients(&rule, &w, &[|s2: f64, c2: f64| d_lobe(s2, c2, p, beta)]);
    let q = synthesis_matrix(degree);
    let smp = twoscale_generate::tables::zh_math::samples();
    let error = |pt: &[f64]| {
        let f_row = coefficients(&rule, &w, &[|s2: f64, c2: f64| s_lobe(s2, c2, pt[0], pt[1])]);
        let h = Array2::from_shape_fn((1, degree), |(_, l)| f_row[[0, l]] * g_row[[0, l]]);
        let c_l = h.dot(&q);
        // s is stored as ln s (value_encoding ln).
        let (s, g) = (lookup(axes, ln_s_vals, pt).exp(), lookup(axes, g_vals, pt));
        let a = 0.5 * (pt[1] + 1.0);
        let (num, den) = smp.iter().zip(c_l.row(0)).fold((0.0, 0.0), |(n, d), (&(sin2, _), &c)| {
            let lobe = s * (1.0 + 4.0 * g * g * sin2).powf(-a);
            (n + (lobe - c) * (lobe - c), d + c * c)
        });
        (num / den).sqrt()
    };
    let (err, worst) = error_map(&format!("lobe from lookup vs C_L (L = {degree}), relative L2"), axes, &slice, error);
    let at = slice.describe(axes);
    let maps = [
        value_map(format!("ln s at {at}"), axes, &slice, ln_s_vals),
        value_map(format!("g at {at}"), axes, &slice, g_vals),
        err,
    ];
    heat_maps(title, &maps, out)?;
    Ok(format!("zh_convolution: worst relative L2 error of the interpolated plain lobe against C_L {worst:.3} ({at})"))
}

/// A material folder's table: its values over its one or two coordinates and
/// the error after interpolation at the cell centres against a direct
/// evaluation. zh_lobe: ln C over (u, theta_h) and |lookup - C| / max(C,
/// 1e-4 max C at that u) against the series from that u's own coefficients.
fn plot_material(
    title: &str,
    m: &twoscale_generate::material::Material,
    table: &str,
    axes: &[Axis],
    values: &[(String, ArrayD<f32>)],
    out: &Path,
) -> Result<String> {
    use twoscale_generate::material::lobe::{derivation, lobe_and_cdf, series};
    match table {
        "zh_lobe" => {
            let ln_c = &values[0].1;
            let slice = Slice { x: 1, y: 0, fixed: vec![0, 0] };
            // The u of every cell centre shown, its series and max C.
            let e = axes[0].encoded();
            let us: Vec<f64> = e.windows(2).map(|w| axes[0].encoding.decode(0.5 * (w[0] + w[1]))).collect();
            let terms = series(&Default::default(), m, &us)?;
            let d = derivation(m);
            let probe: Vec<f64> = (0..=256).map(|k| k as f64 / 256.0 * std::f64::consts::FRAC_PI_2).collect();
            let max_c: Vec<f64> =
                terms.iter().map(|h| lobe_and_cdf(h, &probe).0.into_iter().fold(0.0, f64::max)).collect();
            let error = |pt: &[f64]| {
                let i = us.iter().position(|&u| u == pt[0]).unwrap_or_else(|| {
                    (0..us.len())
                        .min_by(|&a, &b| (us[a] - pt[0]).abs().total_cmp(&(us[b] - pt[0]).abs()))
                        .expect("cells")
                });
                let theta = d.inverse(pt[1], &[pt[0]]);
                let exact = lobe_and_cdf(&terms[i], &[theta]).0[0];
                (lookup(axes, ln_c, pt).exp() - exact).abs() / exact.max(1e-4 * max_c[i])
            };
            let (err, worst) = error_map("|lookup - C| / max(C, 1e-4 max C) at cell centres", axes, &slice, error);
            heat_maps(
                title,
                &[value_map(format!("ln C of {} over (u, v_theta)", m.name), axes, &slice, ln_c), err],
                out,
            )?;
            Ok(format!("zh_lobe of {}: worst pointwise relative error of the lookup against C at the cell centres shown {worst:.2e}", m.name))
        }
        _ => bail!("no picture defined for a material's {table:?} (zh_lobe has one)"),
    }
}
