//! Cost of one zh_lobe lookup as a renderer makes it: the shipped decoding
//! (control variates) against exp of the plainly interpolated ln C.
//! Run: `make bench` (or `cargo bench --bench lookup`).

use criterion::{criterion_group, criterion_main, Criterion};
use ndarray::ArrayD;
use std::hint::black_box;
use twoscale::accuracy::random_points;
use twoscale::interp::interpolate;
use twoscale::tables::zh_lobe::{grid, DERIVATION, SIZES};
use twoscale::tables::zh_lobe_decoding::decode_lobe;

fn zh_lobe_lookup(c: &mut Criterion) {
    // The shipped grid; the cost does not depend on the stored values.
    let axes = grid(SIZES);
    let values = ArrayD::<f32>::zeros(axes.iter().map(|a| a.len()).collect::<Vec<_>>());
    let points: Vec<Vec<f64>> = random_points(&axes[..4], 1000, 7)
        .into_iter()
        .enumerate()
        .map(|(i, mut p)| {
            p.push(std::f64::consts::FRAC_PI_2 * (i % 997) as f64 / 996.0);
            p
        })
        .collect();
    let mut group = c.benchmark_group("zh_lobe_lookup_1000_points");
    group.bench_function("control_variates", |b| {
        b.iter(|| points.iter().map(|p| decode_lobe(&axes, &values, &DERIVATION, &p[..4], p[4]).unwrap()).sum::<f64>())
    });
    group.bench_function("plain", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|p| {
                    let v = DERIVATION.forward(p[4], &[p[0], p[3], p[2]]);
                    interpolate(&axes, &values.view(), &[p[0], p[1], p[2], p[3], v]).unwrap().exp()
                })
                .sum::<f64>()
        })
    });
    black_box(&values);
    group.finish();
}

criterion_group!(benches, zh_lobe_lookup);
criterion_main!(benches);
