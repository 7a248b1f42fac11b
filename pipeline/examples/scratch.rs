use rayon::prelude::*;
use twoscale::grid::Encoding;
use twoscale::tables::epd_math::*;
use twoscale::numerics::special::ln_gamma;
fn lnm1(p: f64) -> f64 { ln_gamma(1.5/p) - ln_gamma(1.0/p) }
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let eps: f64 = args[2].parse().unwrap(); let delta: f64 = args[3].parse().unwrap();
    let enc = if eps > 1.0 { Encoding::ExpNegPower { k: eps } } else { Encoding::BoundedLog { eps, delta } };
    if args[1] == "a" {
        // error along a at fixed p, uniform in enc
        let ps: Vec<f64> = (0..80).map(|i| 1.0/(0.2 + 19.8 * i as f64/79.0)).collect();
        for &na in &[1000usize] {
            let (e0, e1) = (enc.encode(0.0), enc.encode(f64::INFINITY));
            let per: Vec<(f64,f64,f64)> = ps.par_iter().map(|&p| {
                let mut w = (0.0f64, 0.0, 0.0);
                let nodes: Vec<f64> = (0..na).map(|i| g1(p, enc.decode(e0 + (e1-e0)*i as f64/(na-1) as f64))).collect();
                for i in 0..na-1 { let em = e0 + (e1-e0)*(i as f64 + 0.5)/(na-1) as f64; let a = enc.decode(em);
                    let err = (0.5*(nodes[i]+nodes[i+1]) - g1(p, a)).abs(); if err > w.0 { w = (err, p, a); } }
                w }).collect();
            for k in (0..80).step_by(8) { print!("p={:.3}:{:.1e} ", per[k].1, per[k].0); } println!();
            let worst = per.iter().cloned().fold((0.0,0.0,0.0), |x, y| if x.0 > y.0 {x} else {y});
            println!("n_a={na} worst midpoint err {:.2e} at p={:.4} a={:.3e}", worst.0, worst.1, worst.2);
        }
    } else {
        // error along p at fixed a for placements uniform in w(p)
        let na = 1500; let (e0, e1) = (enc.encode(0.0), enc.encode(f64::INFINITY));
        let as_: Vec<f64> = (0..na).map(|i| enc.decode(e0 + (e1-e0)*i as f64/(na-1) as f64)).collect();
        let kappa: f64 = args[4].parse().unwrap(); let mode = args[5].clone();
        let w = |p: f64| match mode.as_str() { "recip" => 1.0/p, "logp" => -p.ln(), "pow" => p.powf(-kappa), "prof" => 1.0/p, _ => lnm1(p) + kappa / p };
        let inv = |wt: f64| { let (mut lo, mut hi) = (0.05f64, 5.0f64); for _ in 0..100 { let m = 0.5*(lo+hi); if w(m) > wt { lo = m } else { hi = m } } 0.5*(lo+hi) };
        for &np in &[if mode == "prof" { 400usize } else { 200 }] {
            let (w0, w1) = (w(5.0), w(0.05));
            let pn: Vec<f64> = (0..np).map(|i| inv(w0 + (w1-w0)*i as f64/(np-1) as f64)).collect();
            if mode == "prof" {
                let cells: Vec<f64> = (0..np-1).into_par_iter().map(|i| { let pm = inv(0.5*(w(pn[i]) + w(pn[i+1])));
                    as_.iter().map(|&a| (0.5*(g1(pn[i],a)+g1(pn[i+1],a)) - g1(pm,a)).abs()).fold(0.0, f64::max) }).collect();
                for t in [1e-4, 7e-5, 5e-5, 3e-5] { let n: f64 = cells.iter().map(|e| (e/t).sqrt().max(1e-9)).sum(); println!("target {t:e}: equidistributed nodes {n:.0}"); }
                let mut cum = 0.0; for (i, e) in cells.iter().enumerate() { cum += e.sqrt(); if i % 20 == 0 { println!("i={i} p={:.4} err={e:.2e} cum_sqrt={cum:.3}", pn[i]); } }
                return;
            }
            let worst = as_.par_iter().map(|&a| {
                let mut r = (0.0f64, 0.0, 0.0);
                let gv: Vec<f64> = pn.iter().map(|&p| g1(p, a)).collect();
                for i in 0..np-1 { let p = inv(0.5*(w(pn[i]) + w(pn[i+1])));  // midpoint in the encoding
                    let err = (0.5*(gv[i]+gv[i+1]) - g1(p, a)).abs(); if err > r.0 { r = (err, p, a); } }
                r }).reduce(|| (0.0,0.0,0.0), |x, y| if x.0 > y.0 {x} else {y});
            println!("mode={mode} kappa={kappa} n_p={np} worst {:.2e} at p={:.4} a={:.3e}", worst.0, worst.1, worst.2);
        }
    }
}
