//! `twoscale fit FILE --compare --report DIR`: the comparison as a self-contained page to look at
//! (docs/fit.md "The report"): DIR/index.html and its PNGs, drawn with plotters:
//! - `spheres.png`: the file's sphere (the render SMAPE is measured on) and each model's, each over its
//!   error in false colour: log2 of the model's pixel luminance over the file's, from a quarter (blue)
//!   to four times (red);
//! - `slices.png`: rho cos theta_o in the plane of incidence against theta_o (negative: towards the light's
//!   side) at four incidences, per channel, log scale: the file evaluated by its reader as points, each
//!   model as a line;
//! - the page's table: every model's parameters, log RMS, relative RMS, render SMAPE and seconds.
//!
//! The page counts its pictures once loaded and says how many loaded (pipeline/fit/tests/test_report.py
//! reads it in headless Chromium). DIR is written under a temporary name beside it and renamed into
//! place.

use anyhow::{bail, Context, Result};
use plotters::prelude::*;
use std::path::Path;
use twoscale_fit::measured::File;
use twoscale_fit::model::{lobe_node, Geometry};
use twoscale_fit::problem::Data;
use twoscale_fit::render::{srgb_exposure, Sphere, RESOLUTION, SCENE};
use twoscale_quality::plot::draw_png;

/// The incidences of the slices (degrees): an RGL file's nearest measured ones stand in.
pub const INCIDENCES: [f64; 4] = [0.0, 30.0, 60.0, 75.0];
/// theta_o's step (degrees) for the models' lines and for the file's points.
const LINE_STEP: f64 = 0.5;
const POINT_STEP: f64 = 3.0;
/// The largest |theta_o| drawn (degrees).
const THETA_MAX: f64 = 88.5;

/// One model of the report.
pub struct Entry {
    pub model: String,
    /// Its parameters as `comparison`'s JSON has them ({"material": {...}, "channels": [...]}), or the
    /// published fit's fields.
    pub parameters: serde_json::Value,
    pub count: usize,
    pub log_rms: f64,
    pub relative_rms: f64,
    pub render_smape: f64,
    pub seconds: f64,
    /// Its sphere image (one RGB value per sphere pixel) and its rho at `Slices::lines`' pairs.
    pub image: Vec<[f64; 3]>,
    pub slices: Vec<[f64; 3]>,
}

/// The slices' direction pairs: wi at each incidence in the xz plane, wo along the plane of incidence.
pub struct Slices {
    /// The incidences (degrees).
    pub incidences: Vec<f64>,
    /// (incidence index, signed theta_o in degrees, wi, wo) of the models' lines and of the file's points.
    pub lines: Vec<(usize, f64, [f64; 3], [f64; 3])>,
    pub points: Vec<(usize, f64, [f64; 3], [f64; 3])>,
}

impl Slices {
    /// `INCIDENCES`, or for an RGL file the nearest of its own incidences.
    pub fn new(file: &File) -> Slices {
        let incidences: Vec<f64> = match file {
            File::Rgl(rgl) => {
                let mut nearest: Vec<f64> = INCIDENCES
                    .iter()
                    .map(|&t| {
                        let own = rgl.theta_i.iter().map(|r| r.to_degrees());
                        own.min_by(|a, b| (a - t).abs().total_cmp(&(b - t).abs())).unwrap_or(t)
                    })
                    .collect();
                // two targets may share a file's incidence: one panel each
                nearest.dedup();
                nearest
            }
            File::Merl(_) => INCIDENCES.to_vec(),
        };
        let pairs = |step: f64| {
            let steps = (THETA_MAX / step).floor() as i64;
            let mut out = Vec::new();
            for (k, &ti) in incidences.iter().enumerate() {
                let t = ti.to_radians();
                let wi = [t.sin(), 0.0, t.cos()];
                for s in -steps..=steps {
                    // theta_o > 0 on the mirror side (x < 0)
                    let to = (s as f64 * step).to_radians();
                    out.push((k, s as f64 * step, wi, [-to.sin(), 0.0, to.cos()]));
                }
            }
            out
        };
        let (lines, points) = (pairs(LINE_STEP), pairs(POINT_STEP));
        Slices { incidences, lines, points }
    }

    /// The lines' pairs as samples, to evaluate a model at: each its own lobe node.
    pub fn data(&self) -> Data {
        let geometry = self.lines.iter().enumerate().map(|(n, (_, _, wi, wo))| Geometry::of(*wi, *wo, n)).collect();
        let nodes = self.lines.iter().map(|(_, _, wi, wo)| lobe_node(*wi, *wo)).collect();
        Data::directions(geometry, nodes)
    }
}

/// What the page says of the fit.
pub struct Page<'a> {
    pub name: &'a str,
    pub file: &'a Path,
    pub format: &'a str,
    /// The model `twoscale fit` wrote.
    pub written: &'a str,
    pub loss: &'a str,
}

/// Refuses DIR where it is not empty, or where its parent is not a folder: before any fitting.
pub fn check(dir: &Path) -> Result<()> {
    let parent = parent(dir);
    if !parent.is_dir() {
        bail!("fit: --report {}: no such directory {}", dir.display(), parent.display());
    }
    if dir.exists() && (!dir.is_dir() || std::fs::read_dir(dir).map(|mut d| d.next().is_some()).unwrap_or(true)) {
        bail!("fit: --report {}: exists and is not an empty folder (give a new one)", dir.display());
    }
    Ok(())
}

fn parent(dir: &Path) -> &Path {
    dir.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Writes the report into DIR (`check`ed): a temporary folder beside it, renamed into place.
pub fn write(
    dir: &Path,
    page: &Page,
    sphere: &Sphere,
    target: &[[f64; 3]],
    file_slices: &[[f64; 3]],
    slices: &Slices,
    entries: &[Entry],
) -> Result<()> {
    let name = dir.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_else(|| "report".into());
    // a folder of its own (removed with what it holds unless renamed into place)
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}.tmp-"))
        .tempdir_in(parent(dir))
        .with_context(|| format!("cannot create a temporary folder beside {}", dir.display()))?;
    let at = tmp.path();
    spheres(&at.join("spheres.png"), sphere, target, entries)?;
    plot_slices(&at.join("slices.png"), slices, file_slices, entries)?;
    std::fs::write(at.join("index.html"), html(page, slices, entries))?;
    if dir.exists() {
        std::fs::remove_dir(dir).with_context(|| format!("cannot replace the empty folder {}", dir.display()))?;
    }
    let at = tmp.keep();
    std::fs::rename(&at, dir).map_err(|e| {
        let _ = std::fs::remove_dir_all(&at);
        anyhow::anyhow!("cannot rename {} to {}: {e}", at.display(), dir.display())
    })
}

/// Pixels per sphere pixel in the picture.
const ZOOM: usize = 2;
const CELL: i32 = (RESOLUTION * ZOOM) as i32;
const COLUMNS: usize = 5;

/// Luminance (Rec. 709).
fn luminance(p: [f64; 3]) -> f64 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The diverging false colour of t in [-1, 1]: blue, white, red.
fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let mix = |a: f64, b: f64, s: f64| (a + (b - a) * s).round() as u8;
    if t < 0.0 {
        RGBColor(mix(255.0, 33.0, -t), mix(255.0, 102.0, -t), mix(255.0, 172.0, -t))
    } else {
        RGBColor(mix(255.0, 178.0, t), mix(255.0, 24.0, t), mix(255.0, 43.0, t))
    }
}

/// The file's sphere and each model's, each over its error map, five to a row.
fn spheres(path: &Path, sphere: &Sphere, target: &[[f64; 3]], entries: &[Entry]) -> Result<()> {
    // the file's exposure for every render alike
    let srgb = srgb_exposure(target);
    let cells = 1 + entries.len();
    let rows = cells.div_ceil(COLUMNS);
    let (cell_w, cell_h) = (CELL + 24, 2 * CELL + 64);
    let size = ((COLUMNS as i32 * cell_w + 16) as u32, (rows as i32 * cell_h + 70) as u32);
    let picture = |image: &[[f64; 3]]| sphere.picture(RESOLUTION, image);
    let truth = picture(target);
    draw_png(path, size, |root| {
        let label = ("sans-serif", 15).into_font().color(&BLACK);
        let small = ("sans-serif", 13).into_font().color(&BLACK);
        for cell in 0..cells {
            let (x0, y0) = (8 + (cell % COLUMNS) as i32 * cell_w, 8 + (cell / COLUMNS) as i32 * cell_h);
            let (title, smape, image) = match cell {
                0 => ("measured file".to_string(), "the reference".to_string(), truth.clone()),
                _ => {
                    let e = &entries[cell - 1];
                    (e.model.clone(), format!("SMAPE {:.4}", e.render_smape), picture(&e.image))
                }
            };
            root.draw(&Text::new(title, (x0, y0), label.clone()))?;
            for (n, p) in image.iter().enumerate() {
                let (row, col) = ((n / RESOLUTION) as i32, (n % RESOLUTION) as i32);
                let colour = RGBColor(srgb(p[0]), srgb(p[1]), srgb(p[2]));
                let error = (cell > 0).then(|| {
                    let (f, t) = (luminance(*p), luminance(truth[n]));
                    match (f > 0.0, t > 0.0) {
                        (true, true) => diverging((f / t).log2() / 2.0),
                        (false, false) => WHITE,
                        (f_lit, _) => diverging(if f_lit { 1.0 } else { -1.0 }),
                    }
                });
                for dy in 0..ZOOM as i32 {
                    for dx in 0..ZOOM as i32 {
                        let (x, y) = (x0 + col * ZOOM as i32 + dx, y0 + 20 + row * ZOOM as i32 + dy);
                        root.draw_pixel((x, y), &colour)?;
                        if let Some(e) = error {
                            root.draw_pixel((x, y + CELL + 6), &e)?;
                        }
                    }
                }
            }
            root.draw(&Text::new(smape, (x0, y0 + 2 * CELL + 32), small.clone()))?;
        }
        // the error maps' scale
        let (x0, y0) = (8, size.1 as i32 - 52);
        root.draw(&Text::new("error maps: pixel luminance, model over file (log scale)", (x0, y0), small.clone()))?;
        let width = 400;
        for i in 0..width {
            let t = 2.0 * i as f64 / (width - 1) as f64 - 1.0;
            root.draw(&Rectangle::new([(x0 + i, y0 + 18), (x0 + i + 1, y0 + 32)], diverging(t).filled()))?;
        }
        for (i, text) in [(0, "1/4 or less"), (width / 2 - 10, "equal"), (width - 70, "4 or more")] {
            root.draw(&Text::new(text, (x0 + i, y0 + 36), small.clone()))?;
        }
        Ok(())
    })
}

/// The models' lines' colours: Tableau's ten, then four darker ones (three two-scale models, seven
/// comparison models and two published fits make twelve).
const PALETTE: [RGBColor; 14] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 128),
    RGBColor(128, 0, 0),
    RGBColor(0, 100, 80),
    RGBColor(90, 0, 120),
];

fn style(k: usize) -> ShapeStyle {
    PALETTE[k % PALETTE.len()].stroke_width(2)
}

/// One panel per incidence (rows) and channel (columns), and the legend.
fn plot_slices(path: &Path, slices: &Slices, file: &[[f64; 3]], entries: &[Entry]) -> Result<()> {
    let (panel_w, panel_h, legend_w) = (420u32, 300u32, 250u32);
    let rows = slices.incidences.len() as u32;
    let size = (3 * panel_w + legend_w, rows * panel_h);
    draw_png(path, size, |root| {
        let (panels, legend) = root.split_horizontally(3 * panel_w);
        let grid = panels.split_evenly((rows as usize, 3));
        for (k, incidence) in slices.incidences.iter().enumerate() {
            for ch in 0..3 {
                let area = &grid[k * 3 + ch];
                // y: rho cos theta_o, over the positive values drawn (log axis)
                let y = |rho: f64, theta: f64| rho * theta.to_radians().cos();
                let mut values: Vec<f64> = Vec::new();
                for (n, &(s, theta, _, _)) in slices.points.iter().enumerate() {
                    if s == k {
                        values.push(y(file[n][ch], theta));
                    }
                }
                for e in entries {
                    for (n, &(s, theta, _, _)) in slices.lines.iter().enumerate() {
                        if s == k {
                            values.push(y(e.slices[n][ch], theta));
                        }
                    }
                }
                let positive: Vec<f64> = values.into_iter().filter(|v| v.is_finite() && *v > 0.0).collect();
                // five decades at most; a panel with nothing above 0 (a black channel) spans 1e-6 to 2e-6 x 1e5
                let top = positive.iter().copied().fold(1e-6, f64::max) * 2.0;
                let least = positive.iter().copied().fold(top, f64::min) / 2.0;
                let floor = (top * 1e-5).max(least).min(top / 10.0);
                let channel = ["red", "green", "blue"][ch];
                let mut chart = ChartBuilder::on(area)
                    .caption(format!("theta_i {incidence:.1} deg, {channel}"), ("sans-serif", 15))
                    .margin(6)
                    .x_label_area_size(30)
                    .y_label_area_size(56)
                    .build_cartesian_2d(-90.0..90.0, (floor..top).log_scale())?;
                chart
                    .configure_mesh()
                    .x_desc("theta_o (deg; > 0 on the mirror side)")
                    .y_desc("rho cos theta_o")
                    .label_style(("sans-serif", 11))
                    .axis_desc_style(("sans-serif", 12))
                    .light_line_style(WHITE.mix(0.0))
                    .draw()?;
                let clamp = |v: f64| v.max(floor);
                for (m, e) in entries.iter().enumerate() {
                    let line = slices.lines.iter().zip(&e.slices).filter(|((s, ..), _)| *s == k);
                    let points: Vec<(f64, f64)> = line.map(|(&(_, t, _, _), r)| (t, clamp(y(r[ch], t)))).collect();
                    chart.draw_series(LineSeries::new(points, style(m)))?;
                }
                let points = slices.points.iter().zip(file).filter(|((s, ..), _)| *s == k);
                chart.draw_series(
                    points.map(|(&(_, t, _, _), r)| Circle::new((t, clamp(y(r[ch], t))), 2, BLACK.filled())),
                )?;
            }
        }
        let font = ("sans-serif", 14).into_font().color(&BLACK);
        legend.draw(&Circle::new((20, 24), 3, BLACK.filled()))?;
        legend.draw(&Text::new("the file (its reader)", (34, 16), font.clone()))?;
        for (m, e) in entries.iter().enumerate() {
            let y = 48 + 22 * m as i32;
            legend.draw(&PathElement::new(vec![(8, y + 8), (30, y + 8)], style(m)))?;
            legend.draw(&Text::new(e.model.clone(), (34, y), font.clone()))?;
        }
        Ok(())
    })
}

/// The parameters of `value` ({"material", "channels"} or a published fit's fields) as "name value" text.
fn parameters_text(value: &serde_json::Value) -> String {
    let fmt = |v: &serde_json::Value| match v {
        serde_json::Value::Number(n) => format!("{:.4}", n.as_f64().unwrap_or(f64::NAN)),
        serde_json::Value::Array(a) => {
            format!(
                "({})",
                a.iter().map(|x| format!("{:.4}", x.as_f64().unwrap_or(f64::NAN))).collect::<Vec<_>>().join(", ")
            )
        }
        other => other.to_string().trim_matches('"').to_string(),
    };
    let skip = ["model", "name", "channel", "wavelength", "error", "material", "other_name"];
    let fields = |o: &serde_json::Map<String, serde_json::Value>| {
        o.iter()
            .filter(|(k, v)| !skip.contains(&k.as_str()) && !v.is_null())
            .map(|(k, v)| format!("{k} {}", fmt(v)))
            .collect::<Vec<_>>()
    };
    let mut parts = Vec::new();
    if let Some(m) = value.get("material").and_then(|m| m.as_object()) {
        parts.push(fields(m).join(", "));
        for c in value.get("channels").and_then(|c| c.as_array()).into_iter().flatten() {
            if let Some(o) = c.as_object() {
                parts.push(format!("{}: {}", fmt(&o["channel"]), fields(o).join(", ")));
            }
        }
    } else if let Some(o) = value.as_object() {
        parts.push(fields(o).join(", "));
    }
    parts.into_iter().filter(|p| !p.is_empty()).collect::<Vec<_>>().join("; ")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn html(page: &Page, slices: &Slices, entries: &[Entry]) -> String {
    let mut rows = String::new();
    for e in entries {
        let mark = if e.model == page.written { " (written)" } else { "" };
        rows += &format!(
            "<tr><td>{}{mark}</td><td class=n>{}</td><td class=n>{:.4}</td><td class=n>{:.4}</td><td class=n>{:.4}</td><td class=n>{:.1}</td><td class=p>{}</td></tr>\n",
            escape(&e.model),
            e.count,
            e.log_rms,
            e.relative_rms,
            e.render_smape,
            e.seconds,
            escape(&parameters_text(&e.parameters))
        );
    }
    let incidences = slices.incidences.iter().map(|t| format!("{t:.1}")).collect::<Vec<_>>().join(", ");
    format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>twoscale fit: {name}</title>
<style>
body {{ font-family: sans-serif; margin: 2em; max-width: 1600px; }}
table {{ border-collapse: collapse; font-size: 90%; }}
td, th {{ border-bottom: 1px solid #ccc; padding: 3px 8px; vertical-align: top; text-align: left; }}
td.n {{ text-align: right; font-variant-numeric: tabular-nums; }}
td.p {{ font-size: 85%; }}
img {{ max-width: 100%; }}
</style></head>
<body>
<h1>{name}: the models compared</h1>
<p>{file} ({format}), fitted by <code>twoscale fit --compare</code>; written: {written}. Every model is fitted on the
same samples with the same loss ({loss}); the published fits are the authors' parameters, not fitted.</p>
<h2>Renders</h2>
<p>The file's sphere and each model's, with the render's SMAPE against the file's; under each, its error. The scene: {scene}.</p>
<img src="spheres.png" alt="the spheres and their errors">
<h2>Slices in the plane of incidence</h2>
<p>rho cos theta_o against theta_o at incidences {incidences} degrees, per channel: the file as its reader evaluates it
(points), each model (lines).</p>
<img src="slices.png" alt="the slices">
<h2>The models</h2>
<p>Log RMS: of ln(1 + cos_i rho) over every valid sample; relative RMS: of rho cos theta_i, relative to the file's;
SMAPE: of the renders above.</p>
<table>
<tr><th>model</th><th>numbers fitted</th><th>log RMS</th><th>relative RMS</th><th>render SMAPE</th><th>seconds</th><th>parameters</th></tr>
{rows}</table>
<p id="pictures">pictures loading</p>
<script>
window.addEventListener("load", () => {{
  const images = [...document.images];
  const loaded = images.filter((i) => i.complete && i.naturalWidth > 0).length;
  document.getElementById("pictures").textContent = `${{loaded}} of ${{images.length}} pictures loaded`;
}});
</script>
</body></html>
"#,
        name = escape(page.name),
        file = escape(&page.file.display().to_string()),
        format = escape(page.format),
        written = escape(page.written),
        loss = escape(page.loss),
        scene = escape(SCENE),
    )
}
