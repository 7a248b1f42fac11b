use twoscale::accuracy::interpolation_error;
use twoscale::grid::{Axis, Encoding};
use twoscale::progress::Progress;
use twoscale::tables::kcorr::{compute, target};
use twoscale::tables::kcorr_math::renorm;
fn main() {
    let n: Vec<usize> = std::env::args().skip(1).map(|a| a.parse().unwrap()).collect();
    let axes = vec![
        Axis::uniform("s", Encoding::LogGap { end: 1.0, eps: 1e-4 }, 0.0, 1.0, n[0]),
        Axis::uniform("b_over_lambda", Encoding::LogPlusLogLog1pSq, 0.1, 1000.0, n[1]),
        Axis::uniform("c", Encoding::ShiftedLog { shift: 1.0 }, 1.01, 101.0, n[2]),
    ];
    let t = std::time::Instant::now();
    let v = compute(&axes, Progress { quiet: true });
    let ct = t.elapsed();
    let e = interpolation_error(&axes, &v, 200_000, 99, |p| renorm(p[0], p[1], p[2]), Some(target));
    println!("{:?} entries {} MB {:.1} compute {:?}: max ratio {:.3} worst {:?}", n, v.len(), v.len() as f64 * 4e-6, ct, e.max_target_ratio.unwrap(), e.worst.map(|w| w.0));
}
