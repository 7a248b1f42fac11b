use rayon::prelude::*;
use twoscale::tables::kcorr_math::*;
use twoscale::numerics::sampling::SplitMix64;
// Encodings as (encode, decode) pairs, by name.
fn enc(name: &str, x: f64) -> f64 {
    match name {
        "lin" => x, "log" => x.ln(), "gap5" => -(1.0 + 1e-5 - x).ln(), "gap6" => -(1.0 + 1e-6 - x).ln(), "gap4" => -(1.0 + 1e-4 - x).ln(),
        "l1p2" => (x * x).ln_1p(), "cm1" => (x - 1.0).ln(), "cm1k" => (x - 1.0 + 0.1).ln(), "cm1k3" => (x - 1.0 + 0.3).ln(), "rec" => 1.0 / x,
        "sqrtgap" => -(1.0 + 1e-5 - x).sqrt(), "loglog" => (x * x).ln_1p().ln(), "mix" => (x * x).ln_1p().ln() + x.ln(),
        _ => panic!() }
}
fn dec(name: &str, e: f64) -> f64 {
    match name {
        "lin" => e, "log" => e.exp(), "gap5" => 1.0 + 1e-5 - (-e).exp(), "gap6" => 1.0 + 1e-6 - (-e).exp(), "gap4" => 1.0 + 1e-4 - (-e).exp(),
        "l1p2" => e.exp_m1().sqrt(), "cm1" => 1.0 + e.exp(), "cm1k" => 1.0 - 0.1 + e.exp(), "cm1k3" => 1.0 - 0.3 + e.exp(), "rec" => 1.0 / e,
        "sqrtgap" => 1.0 + 1e-5 - e * e, "loglog" => e.exp().exp_m1().sqrt(),
        "mix" => { let (mut lo, mut hi) = (1e-3f64, 1e4f64); for _ in 0..200 { let m = (lo * hi).sqrt(); if enc("mix", m) < e { lo = m } else { hi = m } } (lo * hi).sqrt() }
        _ => panic!() }
}
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let encs = [a[1].as_str(), a[2].as_str(), a[3].as_str()];
    let lo = [0.0, 0.1, 1.01]; let hi = [1.0, 1000.0, 101.0];
    let axis: usize = a[4].parse().unwrap(); let n: usize = a[5].parse().unwrap();
    let mut rng = SplitMix64::new(3);
    let others: Vec<[f64; 3]> = (0..4000).map(|_| { let mut p = [0.0; 3]; for d in 0..3 { let (e0, e1) = (enc(encs[d], lo[d]), enc(encs[d], hi[d])); p[d] = dec(encs[d], e0 + (e1 - e0) * rng.uniform()).clamp(lo[d], hi[d]); } p }).collect();
    let (e0, e1) = (enc(encs[axis], lo[axis]), enc(encs[axis], hi[axis]));
    let worst = others.par_iter().map(|p| {
        let mut w = (0.0f64, [0.0; 3]);
        let at = |x: f64| { let mut q = *p; q[axis] = x; renorm(q[0], q[1], q[2]) };
        let nodes: Vec<f64> = (0..n).map(|i| at(if i == 0 { lo[axis] } else if i == n - 1 { hi[axis] } else { dec(encs[axis], e0 + (e1 - e0) * i as f64 / (n - 1) as f64) })).collect();
        for i in 0..n - 1 { let x = dec(encs[axis], e0 + (e1 - e0) * (i as f64 + 0.5) / (n - 1) as f64); let r = at(x);
            let m = (0.5 * (nodes[i] + nodes[i + 1]) - r).abs() / (1e-3 * r).max(1e-6);
            if m > w.0 { let mut q = *p; q[axis] = x; w = (m, q); } }
        w }).reduce(|| (0.0, [0.0; 3]), |x, y| if x.0 > y.0 { x } else { y });
    println!("{:?} axis {axis} n={n}: worst metric {:.3} (C = {:.0}) at {:?}", encs, worst.0, worst.0 * (n * n) as f64, worst.1);
}
