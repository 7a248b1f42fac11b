//! A fast loop for research on zh_lobe's representation (issue 11): builds the
//! table in memory at a grid size, and measures the error after interpolation
//! of a decoding against C computed independently of the table (the same
//! reference and measure as the manifest and `twoscale bench`); optionally
//! where it comes from (one parameter axis off-grid at a time) or along the
//! angles of one point. About 15 s a run on 2 cores at the shipped size.
//!
//!   cargo run --release --example zh_lobe_lab -- [--sizes 17x8x41x23x121]
//!       [--probes bench|manifest] [--seed S] [--count N]
//!       [--decoding shipped|epd-shape]... [--attribution] [--point u,c,p,beta]
//!
//! `shipped` is the decoding of the file contract (`zh_lobe_decoding`).
//! `epd-shape` is the best candidate measured in the stop that wrote this
//! tool, not in the contract: the weight lambda of the diffraction-narrow
//! term is split, lambda^2 of it (faded out below p = 0.5, gone at p = 0.3,
//! where the EPD's grazing spike breaks it) going to
//! logaddexp(ln m_S + ln D(theta_eff), b_tail): the EPD's own shape with its
//! cusp at theta = 0 smoothed by the diffraction core, plus the K-correlation
//! tail over the EPD's mass. Bench probes: p99 2.49 % -> 2.13 %; manifest
//! probes 3.10 % -> 2.68 %; max unchanged (17-19 %, small p, large beta).

use clap::{Parser, ValueEnum};
use ndarray::ArrayD;
use std::f64::consts::FRAC_PI_2;
use twoscale::accuracy::random_points;
use twoscale::bench::zh_lobe::{probes, snapped, PROBE_SEED as BENCH_SEED};
use twoscale::grid::Axis;
use twoscale::interp::interpolate_with;
use twoscale::progress::Progress;
use twoscale::tables::zh::DEFAULT_DEGREE;
use twoscale::tables::zh_lobe::{grid, lobe_errors, reference, table_lobe, LobeJob, DERIVATION, PROBES, PROBE_SEED, SIZES};
use twoscale::tables::zh_lobe_decoding::{ln_m_d, ln_m_s, narrow_ndf_term, slope_variance, weight};
use twoscale::tables::zh_math::ThetaRule;
use twoscale::tables::{Job, Units};

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
enum Decoding {
    Shipped,
    EpdShape,
}

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
enum Probes {
    /// `twoscale bench`'s: uniform in ln(1 + 4u^2), c, ln p, ln beta.
    Bench,
    /// The manifest's: 2000 points, half uniform in the encoded axes, half at cell centres.
    Manifest,
}

#[derive(Parser)]
struct Lab {
    /// Nodes along u, c, p, beta, v_theta (v_theta odd).
    #[arg(long, default_value = "17x8x41x23x121")]
    sizes: String,
    #[arg(long, value_enum, default_value = "bench")]
    probes: Probes,
    /// Seed and count of the bench probes (by default the bench's own).
    #[arg(long, default_value_t = BENCH_SEED)]
    seed: u64,
    #[arg(long, default_value_t = 400)]
    count: usize,
    #[arg(long, value_enum, default_values = ["shipped", "epd-shape"])]
    decoding: Vec<Decoding>,
    /// Also measure with one parameter axis off-grid at a time.
    #[arg(long)]
    attribution: bool,
    /// With --attribution: print every sample above 1 % with only this axis off-grid.
    #[arg(long, value_name = "u|c|p|beta")]
    dump: Option<String>,
    /// Print the error along the angles of this point (u,c,p,beta) instead.
    #[arg(long)]
    point: Option<String>,
}

fn logaddexp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    m + ((a - m).exp() + (b - m).exp()).ln()
}

/// The candidate's control variate at one node or the query point; `lambda`
/// and the fade are the query point's, so they are one constant in the interpolation.
fn epd_shape_term(theta: f64, [u, c, p, beta]: [f64; 4], lambda: f64, fade: f64) -> f64 {
    let (sin, cos) = theta.sin_cos();
    let s2 = slope_variance(p, beta);
    let ws2 = 1.0 / (1.0 + 4.0 * u * u);
    let cos_term = ((cos * cos + s2) / (1.0 + s2)).ln();
    // The K-correlation's tail over the EPD's mass: S at the EPD's rms angle from theta.
    let sig2 = 2.0 * s2 / (1.0 + 2.0 * s2);
    let tail = ln_m_d(p, beta) - 0.5 * (c + 1.0) * (4.0 * u * u * (sin * sin + sig2)).ln_1p() + cos_term;
    // ln D at theta_eff: the cusp of small p smoothed by the diffraction core.
    let th = (theta * theta + 0.25 * ws2).sqrt().min(FRAC_PI_2);
    let ln_d = -(th.tan() / beta).powf(2.0 * p) - 4.0 * (FRAC_PI_2 - th).sin().max(1e-300).ln();
    let narrow = logaddexp(ln_m_s(u, c) + ln_d, tail);
    let mu = lambda * lambda * fade;
    mu * narrow + (lambda - mu) * ln_m_s(u, c) + (1.0 - lambda) * narrow_ndf_term(theta, u, c, p, beta)
}

fn epd_shape_lobe(axes: &[Axis], values: &ArrayD<f32>, pt: &[f64], theta: f64) -> f64 {
    let (u, c, p, beta) = (pt[0], pt[1], pt[2], pt[3]);
    let lambda = weight(u, p, beta);
    let x = ((p - 0.3) / 0.2).clamp(0.0, 1.0);
    let fade = x * x * (3.0 - 2.0 * x);
    let v = DERIVATION.forward(theta, &[u, beta, p]);
    let corrected = interpolate_with(axes, &values.view(), &[u, c, p, beta, v], |cell| {
        let cell = cell.to_vec();
        move |corner: usize| {
            let node: [f64; 5] = std::array::from_fn(|d| axes[d].nodes[cell[d] + (corner >> d & 1)]);
            let th = DERIVATION.inverse(node[4], &[node[0], node[3], node[2]]);
            -epd_shape_term(th, [node[0], node[1], node[2], node[3]], lambda, fade)
        }
    })
    .expect("probe inside the domain");
    (corrected + epd_shape_term(theta, [u, c, p, beta], lambda, fade)).exp()
}

fn lobe(decoding: Decoding, axes: &[Axis], values: &ArrayD<f32>, pt: &[f64], theta: f64) -> f64 {
    match decoding {
        Decoding::Shipped => table_lobe(axes, values, pt, theta),
        Decoding::EpdShape => epd_shape_lobe(axes, values, pt, theta),
    }
}

/// Every (point, angle) sample above 1 % where C >= 1e-4 of the point's maximum.
fn dump(exact: &ndarray::Array2<f64>, points: &[Vec<f64>], lobe: impl Fn(&[f64], f64) -> f64) {
    for (i, pt) in points.iter().enumerate() {
        let max = exact.row(i).iter().fold(0.0f64, |m, x| m.max(*x));
        for k in 0..1000 {
            let (c, theta) = (exact[[i, k]], (1.0 - k as f64 / 1000.0).asin());
            let error = lobe(pt, theta) / c - 1.0;
            if c >= 1e-4 * max && error.abs() > 0.01 {
                let v = DERIVATION.forward(theta, &[pt[0], pt[3], pt[2]]);
                println!("    point {i} u {:.3} c {:.3} p {:.3} beta {:.4} lambda {:.3} theta {theta:.4} v_theta {v:.3} C/max {:.2e} error {:+.2} %",
                         pt[0], pt[1], pt[2], pt[3], weight(pt[0], pt[2], pt[3]), c / max, error * 100.0);
            }
        }
    }
}

fn main() {
    let lab = Lab::parse();
    let sizes: Vec<usize> = lab.sizes.split('x').map(|x| x.parse().expect("sizes: five counts joined by x")).collect();
    let sizes: [usize; 5] = sizes.try_into().expect("sizes: five counts");
    let start = std::time::Instant::now();
    let job = LobeJob::on(grid(sizes), DEFAULT_DEGREE);
    let part = job.compute(Units::all(job.units()), Progress { quiet: true });
    let (axes, values) = (job.axes(), job.values(&part));
    eprintln!("built {sizes:?} in {:.1} s", start.elapsed().as_secs_f64());
    let rule = ThetaRule::standard(DEFAULT_DEGREE);

    if let Some(point) = lab.point {
        let pt: Vec<f64> = point.split(',').map(|x| x.parse().expect("point: u,c,p,beta")).collect();
        let exact = reference(std::slice::from_ref(&pt), &rule, DEFAULT_DEGREE);
        let max = exact.row(0).iter().fold(0.0f64, |m, x| m.max(*x));
        for k in 0..1000 {
            let theta = (1.0 - k as f64 / 1000.0).asin();
            let c = exact[[0, k]];
            let errors: Vec<String> = lab.decoding.iter().map(|&d| format!("{:+.3} %", (lobe(d, axes, &values, &pt, theta) / c - 1.0) * 100.0)).collect();
            println!("k {k:4} theta {theta:.4} C/max {:.3e} {}", c / max, errors.join(" "));
        }
        return;
    }

    let points = match lab.probes {
        Probes::Manifest => random_points(&grid(SIZES)[..4], PROBES, PROBE_SEED),
        Probes::Bench => probes(0.2, lab.count, lab.seed),
    };
    let exact = reference(&points, &rule, DEFAULT_DEGREE);
    for &decoding in &lab.decoding {
        let errors = lobe_errors(&exact, |i, th| lobe(decoding, axes, &values, &points[i], th));
        let s = errors.summary();
        println!("{decoding:?}: p99 {:.3} %, median {:.3} %, max {:.2} %, relative L2 max {:.2} %", s.p99 * 100.0, s.median * 100.0, s.max * 100.0, s.l2_max * 100.0);
        let mut order: Vec<usize> = (0..points.len()).collect();
        order.sort_by(|&a, &b| errors.per_point[b].0.total_cmp(&errors.per_point[a].0));
        for &i in &order[..5] {
            let pt = &points[i];
            println!("  worst: u {:.3} c {:.3} p {:.3} beta {:.4}: {:.2} %", pt[0], pt[1], pt[2], pt[3], errors.per_point[i].0 * 100.0);
        }
        if lab.attribution {
            for (free, name) in [(None, "theta_h only"), (Some(0), "u"), (Some(1), "c"), (Some(2), "p"), (Some(3), "beta")] {
                let moved = snapped(&points, axes, free);
                let exact = reference(&moved, &rule, DEFAULT_DEGREE);
                let s = lobe_errors(&exact, |i, th| lobe(decoding, axes, &values, &moved[i], th)).summary();
                println!("  off-grid {name}: p99 {:.3} %, max {:.2} %", s.p99 * 100.0, s.max * 100.0);
                if lab.dump.as_deref() == Some(name) {
                    dump(&exact, &moved, |pt, th| lobe(decoding, axes, &values, pt, th));
                }
            }
        }
    }
}
