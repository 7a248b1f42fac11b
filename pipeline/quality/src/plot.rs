//! PNG pictures: time against error (`twoscale bench`) and slices of a table
//! with their measured error (`twoscale plot`). Text uses the embedded DejaVu
//! Sans, so pictures look the same on every machine.

use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use std::path::Path;
use std::sync::Once;
use twoscale_tables::axis::Axis;
use twoscale_tables::table::write_bytes_atomic;

/// A PNG's drawing area (`draw_png`).
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

fn register_font() {
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans is a valid font"));
    });
}

/// Draws into an RGB buffer, encodes it as a PNG and writes it to a temporary file next to `path`, then
/// renames it: no partial picture is left behind.
pub fn draw_png(path: &Path, size: (u32, u32), draw: impl FnOnce(&Area) -> Result<()>) -> Result<()> {
    register_font();
    let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
    }
    write_bytes_atomic(path, &rgb_png(&rgb, size)).with_context(|| format!("cannot write {}", path.display()))
}

/// An 8-bit RGB PNG of `rgb` (rows top to bottom, 3 bytes a pixel), in memory.
pub fn rgb_png(rgb: &[u8], (width, height): (u32, u32)) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().expect("a PNG header in memory");
    writer.write_image_data(rgb).expect("a PNG of the picture's size, in memory");
    drop(writer);
    bytes
}

/// Short numeric label: 3 significant digits, exponent form outside [1e-3, 1e4).
pub fn short(x: f64) -> String {
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e4).contains(&a) {
        format!("{x:.1e}")
    } else {
        let s = format!("{x:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

const SERIES_COLORS: [RGBColor; 4] =
    [RGBColor(31, 119, 180), RGBColor(44, 160, 44), RGBColor(148, 103, 189), RGBColor(255, 127, 14)];
const BASELINE_COLOR: RGBColor = RGBColor(214, 39, 40);

/// One marker of a scatter panel.
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub series: &'static str,
    /// Drawn as a triangle in the baseline colour.
    pub baseline: bool,
    /// Competes for the Pareto front (a diagnostic marker, such as an error
    /// attribution, does not).
    pub contender: bool,
    pub label: String,
}

/// A log-log scatter panel; its Pareto front (no other marker both lower
/// and to the left) is joined and drawn larger.
pub struct Scatter {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub markers: Vec<Marker>,
}

/// Marks the contenders on the front: sorted by y then x, each with an x below all before it.
fn pareto_front(markers: &[Marker]) -> Vec<bool> {
    let mut order: Vec<usize> = (0..markers.len()).filter(|&i| markers[i].contender).collect();
    order.sort_by(|&a, &b| markers[a].y.total_cmp(&markers[b].y).then(markers[a].x.total_cmp(&markers[b].x)));
    let (mut front, mut best) = (vec![false; markers.len()], f64::INFINITY);
    for i in order {
        front[i] = markers[i].x < best;
        best = best.min(markers[i].x);
    }
    front
}

/// One panel; `series` orders the series of every panel, so that a series
/// has the same colour in each.
fn scatter_panel(area: &Area, panel: &Scatter, series: &[&str]) -> Result<()> {
    let markers = &panel.markers;
    if markers.is_empty() {
        area.titled(&format!("{}: not measured", panel.title), ("sans-serif", 18))?;
        return Ok(());
    }
    let points: Vec<(f64, f64)> = markers.iter().map(|m| (m.x.max(1e-16), m.y)).collect();
    let (x0, x1) = points.iter().fold((f64::INFINITY, 0.0f64), |m, p| (m.0.min(p.0), m.1.max(p.0)));
    let (y0, y1) = points.iter().fold((f64::INFINITY, 0.0f64), |m, p| (m.0.min(p.1), m.1.max(p.1)));
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(64)
        .build_cartesian_2d((x0 / 3.0..x1 * 10.0).log_scale(), (y0 / 3.0..y1 * 5.0).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .x_labels(8)
        .y_labels(8)
        .light_line_style(BLACK.mix(0.04))
        .bold_line_style(BLACK.mix(0.15))
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| short(*y))
        .label_style(("sans-serif", 13))
        .draw()?;
    let on_front = pareto_front(markers);
    let mut front: Vec<(f64, f64)> = points.iter().zip(&on_front).filter(|(_, f)| **f).map(|(p, _)| *p).collect();
    front.sort_by(|a, b| a.1.total_cmp(&b.1));
    chart
        .draw_series(LineSeries::new(front, ShapeStyle::from(&BLACK.mix(0.5)).stroke_width(2)))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.5).stroke_width(2)));
    // Labels of markers at one y (an error attribution beside the plain decoding, of
    // any series) alternate between two heights in the order of x.
    let raised = |k: usize| {
        let (x, y) = points[k];
        points.iter().enumerate().filter(|&(j, p)| p.1 == y && (p.0, j) < (x, k)).count() % 2 == 1
    };
    for (i, name) in series.iter().enumerate().filter(|(_, name)| markers.iter().any(|m| m.series == **name)) {
        let baseline = markers.iter().any(|m| m.series == *name && m.baseline);
        let color = if baseline { BASELINE_COLOR } else { SERIES_COLORS[i % SERIES_COLORS.len()] };
        let mine: Vec<(&Marker, (f64, f64), bool, bool)> = (0..markers.len())
            .filter(|&k| markers[k].series == *name)
            .map(|k| (&markers[k], points[k], on_front[k], raised(k)))
            .collect();
        chart
            .draw_series(mine.iter().map(|(_, p, front, _)| {
                let size = if *front { 7 } else { 5 };
                if baseline {
                    TriangleMarker::new(*p, size, color.filled()).into_dyn()
                } else {
                    Circle::new(*p, size, color.filled()).into_dyn()
                }
            }))?
            .label(*name)
            .legend(move |(x, y)| {
                if baseline {
                    TriangleMarker::new((x + 8, y), 5, color.filled()).into_dyn()
                } else {
                    Circle::new((x + 8, y), 5, color.filled()).into_dyn()
                }
            });
        chart.draw_series(mine.iter().map(|(m, p, _, raised)| {
            let offset = (8, -14 - 12 * i32::from(*raised));
            EmptyElement::at(*p) + Text::new(m.label.clone(), offset, ("sans-serif", 12).into_font().color(&color))
        }))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 12))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

/// Scatter panels side by side (1600 x 700) under `title`.
pub fn scatter_panels(title: &str, panels: &[Scatter; 2], path: &Path) -> Result<()> {
    draw_png(path, (1600, 700), |root| {
        let root = root.titled(title, ("sans-serif", 24))?;
        let areas = root.split_evenly((1, 2));
        let mut series: Vec<&str> = Vec::new();
        for m in panels.iter().flat_map(|p| &p.markers) {
            if !series.contains(&m.series) {
                series.push(m.series);
            }
        }
        for (area, panel) in areas.iter().zip(panels) {
            scatter_panel(area, panel, &series)?;
        }
        Ok(())
    })
}

/// A heat map: `values[j][i]` over cells [x_edges[i], x_edges[i+1]] x
/// [y_edges[j], y_edges[j+1]] in encoded coordinates, ticks labelled with decoded values.
pub struct HeatMap<'a> {
    pub title: String,
    pub x: &'a Axis,
    pub y: &'a Axis,
    pub x_edges: Vec<f64>,
    pub y_edges: Vec<f64>,
    pub values: Vec<Vec<f64>>,
    /// Colour by log10 of the value (errors).
    pub log: bool,
}

/// Cell edges around nodes: midpoints between encoded nodes, half a cell beyond the ends.
pub fn node_edges(axis: &Axis) -> Vec<f64> {
    let e = axis.encoded();
    let n = e.len();
    if n == 1 {
        return vec![e[0] - 0.5, e[0] + 0.5];
    }
    let mut out = vec![e[0] - 0.5 * (e[1] - e[0])];
    out.extend(e.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    out.push(e[n - 1] + 0.5 * (e[n - 1] - e[n - 2]));
    out
}

fn draw_heat_map(area: &Area, map: &HeatMap) -> Result<()> {
    let (plot_area, bar_area) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(90));
    let shown = |v: f64| if map.log { v.max(1e-16).log10() } else { v };
    let finite: Vec<f64> = map.values.iter().flatten().map(|&v| shown(v)).filter(|v| v.is_finite()).collect();
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 0.5, lo + 0.5) };
    let color = |v: f64| ViridisRGB.get_color_normalized(shown(v).clamp(lo, hi), lo, hi);
    let (xe, ye) = (&map.x_edges, &map.y_edges);
    let mut chart = ChartBuilder::on(&plot_area)
        .caption(&map.title, ("sans-serif", 17))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xe[0]..xe[xe.len() - 1], ye[0]..ye[ye.len() - 1])?;
    let (xa, ya) = (map.x, map.y);
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(format!("{} ({})", xa.name, xa.encoding.formula()))
        .y_desc(ya.name.clone())
        .x_label_formatter(&|e| short(xa.encoding.decode(*e)))
        .y_label_formatter(&|e| short(ya.encoding.decode(*e)))
        .label_style(("sans-serif", 12))
        .draw()?;
    chart.draw_series(map.values.iter().enumerate().flat_map(|(j, row)| {
        row.iter().enumerate().map(move |(i, &v)| {
            let fill = if v.is_finite() { color(v).filled() } else { WHITE.filled() };
            Rectangle::new([(xe[i], ye[j]), (xe[i + 1], ye[j + 1])], fill)
        })
    }))?;
    // Colour bar with its range.
    let mut bar = ChartBuilder::on(&bar_area)
        .margin_top(40)
        .margin_bottom(50)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&|v| if map.log { format!("{:.1e}", 10f64.powf(*v)) } else { short(*v) })
        .label_style(("sans-serif", 11))
        .draw()?;
    let steps = 100;
    bar.draw_series((0..steps).map(|k| {
        let (a, b) = (lo + (hi - lo) * k as f64 / steps as f64, lo + (hi - lo) * (k + 1) as f64 / steps as f64);
        Rectangle::new([(0.0, a), (1.0, b)], ViridisRGB.get_color_normalized(0.5 * (a + b), lo, hi).filled())
    }))?;
    Ok(())
}

/// Heat maps side by side, under a title.
pub fn heat_maps(title: &str, maps: &[HeatMap], path: &Path) -> Result<()> {
    let width = 620 * maps.len() as u32;
    draw_png(path, (width, 600), |root| {
        let root = root.titled(title, ("sans-serif", 20))?;
        for (area, map) in root.split_evenly((1, maps.len())).iter().zip(maps) {
            draw_heat_map(area, map)?;
        }
        Ok(())
    })
}

/// A 1-D table: its values (left) and the error at the cell centres (right, log).
pub fn line_pair(
    title: &str,
    axis: &Axis,
    values: &[f64],
    centres: &[(f64, f64)],
    error_label: &str,
    path: &Path,
) -> Result<()> {
    draw_png(path, (1240, 560), |root| {
        let root = root.titled(title, ("sans-serif", 20))?;
        let halves = root.split_evenly((1, 2));
        let e = axis.encoded();
        let (lo, hi) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, &v| (m.0.min(v), m.1.max(v)));
        let mut chart = ChartBuilder::on(&halves[0])
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(e[0].min(e[e.len() - 1])..e[0].max(e[e.len() - 1]), lo..hi + 1e-12)?;
        chart
            .configure_mesh()
            .x_desc(&axis.name)
            .x_label_formatter(&|x| short(axis.encoding.decode(*x)))
            .label_style(("sans-serif", 12))
            .draw()?;
        chart.draw_series(LineSeries::new(e.iter().copied().zip(values.iter().copied()), &SERIES_COLORS[0]))?;
        let pts: Vec<(f64, f64)> = centres.iter().map(|&(x, err)| (x, err.max(1e-17))).collect();
        let (y0, y1) = pts.iter().fold((f64::INFINITY, 0.0f64), |m, p| (m.0.min(p.1), m.1.max(p.1)));
        let mut chart = ChartBuilder::on(&halves[1])
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(e[0].min(e[e.len() - 1])..e[0].max(e[e.len() - 1]), (y0 / 2.0..y1 * 2.0).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(&axis.name)
            .y_desc(error_label)
            .x_label_formatter(&|x| short(axis.encoding.decode(*x)))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 2, BASELINE_COLOR.filled())))?;
        Ok(())
    })
}
