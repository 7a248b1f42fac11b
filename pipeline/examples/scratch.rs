use twoscale::tables::zh_math::*;
fn main() {
    let degree = 2000;
    let rules = [ThetaRule::new(degree, 24, 1.2, 0.02), ThetaRule::new(degree, 20, 1.25, 0.02).clone(), ThetaRule::new(degree, 48, 1.06, 0.005)];
    let lobes = [|s2: f64, c2: f64| d_lobe(s2, c2, 0.005, 5.0)];
    let c: Vec<Vec<f64>> = rules.iter().map(|r| coefficients(r, &r.weighted_legendre(degree), &lobes).row(0).to_vec()).collect();
    let sc = c[2].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = |a: &Vec<f64>, b: &Vec<f64>| a.iter().zip(b).fold(0.0f64, |m, (p, q)| m.max((p - q).abs())) / sc;
    println!("nodes {} {} {}", rules[0].len(), rules[1].len(), rules[2].len());
    let r3 = ThetaRule::new(degree, 28, 1.2, 0.02); let c3 = coefficients(&r3, &r3.weighted_legendre(degree), &lobes).row(0).to_vec(); println!("24/1.2: {:e}  28/1.2: {:e} (nodes {})", d(&c[0], &c[2]), d(&c3, &c[2]), r3.len());
    println!("std-ref {:e} std-fine {:e} ref-fine {:e}", d(&c[0], &c[1]), d(&c[0], &c[2]), d(&c[1], &c[2]));
    let at = |v: &Vec<f64>| (0..degree).step_by(250).map(|l| v[l] / sc).collect::<Vec<_>>();
    println!("G_l/max at l=0,250,..: {:?}", at(&c[2]));
}
