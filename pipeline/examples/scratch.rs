use twoscale::tables::epd_math::*;
use twoscale::numerics::special::erfc;
fn beck(a: f64) -> f64 { let mu = 1.0/a; 0.5*((-mu*mu).exp()/(mu*std::f64::consts::PI.sqrt()) - erfc(mu)) }
fn main() {
    let mut worst = 0.0f64;
    for i in 0..=60 { let a = 10f64.powf(-3.0 + 6.0*i as f64/60.0);
        let l = lambda_integral(1.0, a); let b = beck(a);
        let rel = if b > 0.0 { (l.value/b - 1.0).abs() } else { l.value };
        worst = worst.max(rel);
        if i % 6 == 0 || rel > 1e-13 { println!("a={a:.3e} lam={:.15e} beck={b:.15e} rel={rel:.2e} evals={} conv={}", l.value, l.evaluations, l.converged); }
    }
    println!("worst beckmann rel {worst:.3e}");
    for &p in &[0.05, 0.2, 1.0, 5.0] { for &a in &[1e-16, 1e-12, 1e-6, 1e-2, 1.0, 1e2, 1e6, 1e30] {
        let l = lambda_integral(p, a);
        println!("p={p} a={a:e} lam={:.6e} asym={:.6e} evals={} conv={}", l.value, a*m1(p)-0.5, l.evaluations, l.converged);
    }}
    let t = std::time::Instant::now(); let mut n = 0usize; let mut ev = 0usize;
    for i in 0..100 { let p = 5.0/(i as f64+1.0); for j in 0..999 { let a = 1.0/(1000.0/(j as f64+1.0)).ln().powi(20); let l = lambda_integral(p, a); ev += l.evaluations; n+=1; if !l.converged {println!("nc p={p} a={a}");} } }
    let t = std::time::Instant::now(); let mut acc=0.0; for i in 0..100 { let p = 5.0/(i as f64+1.0); for j in 0..999 { let a = 1.0/(1000.0/(j as f64+1.0)).ln().powi(20); acc += g1(p,a);}} println!("g1 paper grid {:?} {acc}", t.elapsed());
    println!("paper grid {n} in {:?}, mean evals {}", t.elapsed(), ev as f64/n as f64);
}
#[allow(dead_code)]
fn t2() {}
