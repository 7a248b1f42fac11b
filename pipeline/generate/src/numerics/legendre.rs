//! Legendre polynomials and Gauss-Legendre rules.

/// P_0(t) .. P_{n-1}(t) into `out` (length n), by the three-term recurrence
/// (l+1) P_{l+1} = (2l+1) t P_l - l P_{l-1} (stable on [-1, 1]).
pub fn legendre_all(t: f64, out: &mut [f64]) {
    let n = out.len();
    if n == 0 {
        return;
    }
    out[0] = 1.0;
    if n > 1 {
        out[1] = t;
    }
    for l in 1..n.saturating_sub(1) {
        let lf = l as f64;
        out[l + 1] = ((2.0 * lf + 1.0) * t * out[l] - lf * out[l - 1]) / (lf + 1.0);
    }
}

/// P_n(t) and its derivative, for Newton's method.
fn legendre_with_derivative(n: usize, t: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, t);
    for l in 1..n {
        let lf = l as f64;
        let p2 = ((2.0 * lf + 1.0) * t * p1 - lf * p0) / (lf + 1.0);
        p0 = p1;
        p1 = p2;
    }
    let dp = n as f64 * (t * p1 - p0) / (t * t - 1.0);
    (p1, dp)
}

/// The n-point Gauss-Legendre rule on [-1, 1]: (nodes ascending, weights).
/// Newton from Tricomi's initial guesses, to machine precision.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        let mut t = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre_with_derivative(n, t);
            let dt = p / dp;
            t -= dt;
            if dt.abs() < 1e-16 {
                break;
            }
        }
        let (_, dp) = legendre_with_derivative(n, t);
        let wi = 2.0 / ((1.0 - t * t) * dp * dp);
        x[n - 1 - i] = t;
        x[i] = -t;
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    (x, w)
}

/// A composite Gauss-Legendre rule: `n` nodes in each panel between
/// consecutive `breaks`. Returns (nodes, weights) on the whole interval.
pub fn composite_rule(breaks: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let (gx, gw) = gauss_legendre(n);
    let mut nodes = Vec::with_capacity(n * breaks.len());
    let mut weights = Vec::with_capacity(n * breaks.len());
    for pair in breaks.windows(2) {
        let (c, h) = (0.5 * (pair[0] + pair[1]), 0.5 * (pair[1] - pair[0]));
        for (x, w) in gx.iter().zip(&gw) {
            nodes.push(c + h * x);
            weights.push(h * w);
        }
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_known_values() {
        let mut p = [0.0; 5];
        legendre_all(0.5, &mut p);
        // P2(0.5) = -0.125, P3(0.5) = -0.4375, P4(0.5) = -0.2890625
        assert_eq!(p[..2], [1.0, 0.5]);
        assert!((p[2] + 0.125).abs() < 1e-15 && (p[3] + 0.4375).abs() < 1e-15 && (p[4] + 0.2890625).abs() < 1e-15);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 20, 64] {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14, "n={n}");
            for deg in 0..(2 * n) {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg as f64 + 1.0) };
                assert!((got - exact).abs() < 1e-13, "n={n} degree {deg}: {got} vs {exact}");
            }
        }
        // Orthogonality of P_l under a rule exact to degree 2n-1.
        let (x, w) = gauss_legendre(30);
        let mut p = vec![0.0; 20];
        let mut gram = vec![0.0; 400];
        for (xi, wi) in x.iter().zip(&w) {
            legendre_all(*xi, &mut p);
            for a in 0..20 {
                for b in 0..20 {
                    gram[a * 20 + b] += wi * p[a] * p[b];
                }
            }
        }
        for a in 0..20 {
            for b in 0..20 {
                let exact = if a == b { 2.0 / (2.0 * a as f64 + 1.0) } else { 0.0 };
                assert!((gram[a * 20 + b] - exact).abs() < 1e-13);
            }
        }
    }
}
