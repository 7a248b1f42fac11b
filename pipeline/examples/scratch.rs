use twoscale::tables::zh_math::*;
fn cl(u: f64, c: f64, beta: f64, p: f64, l: usize, rule: &ThetaRule) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let w = rule.weighted_legendre(l);
    let f = coefficients(rule, &w, &[|s2: f64, c2: f64| s_lobe(s2, c2, u, c)]);
    let g = coefficients(rule, &w, &[|s2: f64, c2: f64| d_lobe(s2, c2, beta, p)]);
    let q = synthesis_matrix(l);
    let h = &f.row(0) * &g.row(0);
    (h.dot(&q).to_vec(), f.row(0).to_vec(), g.row(0).to_vec())
}
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|x| x.parse().unwrap()).collect();
    let (u, c, beta, p, l) = (a[0], a[1], a[2], a[3], a[4] as usize);
    let rule = ThetaRule::standard(l);
    let t = std::time::Instant::now();
    let (cl_std, f1, g1) = cl(u, c, beta, p, l, &rule);
    println!("rule nodes {} time {:?}", rule.len(), t.elapsed());
    let (_, f2, g2) = cl(u, c, beta, p, l, &ThetaRule::refined(l));
    let fmax = f1.iter().fold(0.0f64, |m, x| m.max(x.abs())); let gmax = g1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let df = f1.iter().zip(&f2).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / fmax;
    let dg = g1.iter().zip(&g2).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / gmax;
    println!("coef convergence: F {df:.2e} G {dg:.2e}");
    let samp = samples();
    let cmax = cl_std.iter().fold(0.0f64, |m, x| m.max(*x));
    let t = std::time::Instant::now(); let mut worst = 0.0f64;
    for k in (0..1000).step_by(50).chain([999, 990, 980, 960]) {
        let th = samp[k].0.sqrt().asin();
        let ex = exact_convolution(th, u, c, beta, p, 1e-10);
        let e = (cl_std[k] - ex).abs() / cmax; worst = worst.max(e);
        if k % 200 == 0 || k > 950 { println!("k={k} th={th:.4} CL={:.10e} exact={ex:.10e} err/max={e:.2e}", cl_std[k]); }
    }
    println!("worst {worst:.2e}; 24 exact evals in {:?}", t.elapsed());
}
