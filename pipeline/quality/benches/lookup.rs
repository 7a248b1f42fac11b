//! Cost of one zh_lobe lookup as a renderer makes it (`Lookup::decode`: the
//! derived angle, five datasets interpolated with one cell search, the
//! control variates at the point, exp), against its floor measured in the
//! same run: plain multilinear interpolation of c_lobe alone at the stored
//! point; on the default table and on a scene-sized one.
//! Run: `make bench` (or `cargo bench -p twoscale-quality --bench lookup`).

use criterion::{criterion_group, criterion_main, Criterion};
use ndarray::ArrayD;
use twoscale_generate::accuracy::random_points;
use twoscale_generate::tables::zh_lobe::{grid, lobe_lookup, lobe_values, SIZES};
use twoscale_tables::axis::Axis;
use twoscale_tables::interp::interpolate;

/// `Lookup::decode` against plain interpolation of c_lobe alone at 1000
/// random points of `axes` (the cost does not depend on the stored ln C).
fn bench_on(c: &mut Criterion, group: &str, axes: Vec<Axis>) {
    let ln_c = ArrayD::<f32>::zeros(axes.iter().map(|a| a.len()).collect::<Vec<_>>());
    let lobe = lobe_lookup(&axes, lobe_values(&axes, ln_c.clone()));
    let points: Vec<Vec<f64>> = random_points(&axes[..4], 1000, 7)
        .into_iter()
        .enumerate()
        .map(|(i, p)| vec![p[0], p[1], p[2], p[3], std::f64::consts::FRAC_PI_2 * (i % 997) as f64 / 996.0])
        .collect();
    let stored: Vec<Vec<f64>> = points.iter().map(|p| lobe.stored_point(p).expect("inside")).collect();
    let c_lobe = ln_c.view();
    let mut group = c.benchmark_group(group);
    group.bench_function("decode", |b| {
        b.iter(|| points.iter().map(|p| lobe.decode(p).expect("inside")[0]).sum::<f64>())
    });
    group.bench_function("interpolate_c_lobe_only", |b| {
        b.iter(|| stored.iter().map(|p| interpolate(&axes, &c_lobe, p).expect("inside")).sum::<f64>())
    });
    group.finish();
}

fn zh_lobe_lookup(c: &mut Criterion) {
    // The shipped grid: 310 MB, the corners' cache lines come from memory.
    bench_on(c, "zh_lobe_default_table_1000_points", grid(SIZES));
    // A scene's sub-domain (merl_nickel's node ranges: 5 x 2 x 2 x 2 x 121 nodes), in cache.
    let ranges = [0..=4, 4..=5, 21..=22, 8..=9, 0..=120];
    let small = grid(SIZES).iter().zip(ranges).map(|(a, r)| a.slice(r)).collect();
    bench_on(c, "zh_lobe_scene_table_1000_points", small);
}

criterion_group!(benches, zh_lobe_lookup);
criterion_main!(benches);
