use twoscale::tables::zh_math::*;
use twoscale::tables::zh_fit::*;
fn main() {
    let (u, c, beta, p) = (0.8, 3.02, 0.95 * 0.348, 0.6);
    let l = 100; let rule = ThetaRule::standard(l); let w = rule.weighted_legendre(l);
    let f = coefficients(&rule, &w, &[|s2: f64, c2: f64| s_lobe(s2, c2, u, c)]);
    let g = coefficients(&rule, &w, &[|s2: f64, c2: f64| d_lobe(s2, c2, beta, p)]);
    let data = (&f.row(0) * &g.row(0)).dot(&synthesis_matrix(l)).to_vec();
    let smp = samples();
    let sin2: Vec<f64> = smp.iter().map(|x| x.0).collect(); let cos2: Vec<f64> = smp.iter().map(|x| x.1).collect();
    println!("data k=0 {:e} k=500 {:e} k=999 {:e}", data[0], data[500], data[999]);
    let st = initial_guess(&sin2, &cos2, &data, c); println!("start {st:?}");
    println!("{:?}", fit(&sin2, &cos2, &data, c, st));
    let ones = vec![1.0; 1000];
    let st = initial_guess(&sin2, &ones, &data, c); println!("plain start {st:?} {:?}", fit(&sin2, &ones, &data, c, st));
}
