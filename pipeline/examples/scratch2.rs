use twoscale::tables::zh::*;
use twoscale::tables::zh_math::*;
use twoscale::tables::zh_fit::*;
use std::f64::consts::PI;
fn main() {
    let (u, c, beta, p) = (10.609024555568752, 2.2199999999999998, 0.028117066259517463, 0.2);
    let l = 2000; let rule = ThetaRule::standard(l); let w = rule.weighted_legendre(l);
    let f = coefficients(&rule, &w, &[|s2: f64, c2: f64| s_lobe(s2, c2, u, c)]);
    let g = coefficients(&rule, &w, &[|s2: f64, c2: f64| d_lobe(s2, c2, beta, p)]);
    let h = (&f.row(0) * &g.row(0)).to_vec();
    let wt: Vec<f64> = (0..l).map(|k| PI * (2 * k + 1) as f64).collect();
    let deg = auto_degree(&h, &wt);
    let q = synthesis_matrix(l);
    let data: Vec<f64> = (0..1000).map(|k| (0..deg).map(|j| h[j] * q[[j, k]]).sum()).collect();
    let smp = samples(); let sin2: Vec<f64> = smp.iter().map(|x| x.0).collect(); let cos2: Vec<f64> = smp.iter().map(|x| x.1).collect();
    for k in [0, 100, 300, 500, 700, 900, 990, 999] { println!("k={k} C={:e}", data[k]); }
    let st = initial_guess(&sin2, &cos2, &data, c); println!("start {st:?}");
    let r = fit(&sin2, &cos2, &data, c, st); println!("{r:?}");
    let r2 = fit(&sin2, &cos2, &data, c, (r.s, r.g)); println!("continued: {r2:?}");
    let r3 = fit(&sin2, &cos2, &data, c, (r2.s, r2.g)); println!("continued: {r3:?}");
}
