//! The layered models' interface albedo (docs/maths.md section 10), at any parameters: a plastic is
//! the two-scale interface with the dielectric Fresnel factor F_eta over a Lambertian layer,
//!
//!   rho = F_eta(cos_d) rho_I + d_eff T(i) T(o) / (pi T_avg),   T(mu) = max(1 - E_F(mu), 0),
//!   E_F(mu) = int F_eta rho_I cos theta_o do,   T_avg = 2 int T mu dmu,
//!   d_eff = d (1 - r) / (1 - d r),   r = 1 - T_avg / eta^2.
//!
//! E_F is integrated over the half vector at incidences uniform in theta_i (T read between them
//! linearly in theta): x = ln tan theta_h on nodes over [ln 1e-4, ln 1e3] (trapezoid; the integrand
//! decays doubly exponentially at both ends, beta >= 0.005), phi on Gauss-Legendre nodes over
//! [0, pi] (the integrand is even in phi), with
//! do = 4 (i.h) dh and dh = sin^2 theta_h cos theta_h dx dphi. The rule was chosen by comparing it
//! with the per-material `interface_albedo` tables (docs/fit.md). The direction pairs are fixed, so
//! the model's parts at them are computed like a MERL file's samples (`GeneralTables::parts`).

use crate::model::{Geometry, Parts};
use std::f64::consts::{FRAC_PI_2, PI};
use twoscale_tables::fresnel;

/// The last incidence: cos theta_i = 1e-3 (T beyond it is T there).
fn theta_max() -> f64 {
    1e-3f64.acos()
}
const X_RANGE: (f64, f64) = (-9.210340371976182, 6.907755278982137); // ln 1e-4, ln 1e3

/// The direction pairs of the E_F quadrature, their lobe nodes, weights and incidences.
pub struct Quadrature {
    pub geometry: Vec<Geometry>,
    pub nodes: Vec<(f64, f64)>,
    /// The incidences theta_i, uniform in [0, acos 1e-3].
    pub incidences: Vec<f64>,
    weight: Vec<f64>,
    incidence: Vec<usize>,
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre recurrence).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    (p0, p1) = (p1, p2);
                }
                let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    return (x, 2.0 / ((1.0 - x * x) * dp * dp));
                }
            }
        })
        .collect()
}

impl Quadrature {
    /// The fit's rule: 12 incidences x 120 x 16 (13,121 direction pairs). Against the per-material
    /// interface_albedo tables of the six test plastics it is within 8e-4, and 3.7e-3 at the last
    /// incidence (cos theta_i = 1e-3, where o's cut at the horizon defeats the phi rule); 24 x 200
    /// x 24 (65,727 pairs) gives 4.7e-4 and 1.7e-3 at five times the cost (docs/fit.md).
    pub fn fit() -> Quadrature {
        Quadrature::new(12, 120, 16)
    }

    /// `incidences` x (`x_nodes` in ln tan theta_h x `phi_nodes` in phi) direction pairs.
    pub fn new(incidences: usize, x_nodes: usize, phi_nodes: usize) -> Quadrature {
        let (mut geometry, mut nodes, mut weight, mut incidence) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let phis = gauss_legendre(phi_nodes);
        let dx = (X_RANGE.1 - X_RANGE.0) / (x_nodes - 1) as f64;
        let thetas: Vec<f64> = (0..incidences).map(|k| k as f64 / (incidences - 1) as f64 * theta_max()).collect();
        for (k, &theta_i) in thetas.iter().enumerate() {
            let i = [theta_i.sin(), 0.0, theta_i.cos()];
            for a in 0..x_nodes {
                let tan_h = (X_RANGE.0 + a as f64 * dx).exp();
                let theta_h = tan_h.atan();
                let (sh, chh) = theta_h.sin_cos();
                let wx = if a == 0 || a == x_nodes - 1 { 0.5 * dx } else { dx };
                for &(t, wt) in &phis {
                    let phi = FRAC_PI_2 * (t + 1.0);
                    let h = [sh * phi.cos(), sh * phi.sin(), chh];
                    let ih = i[0] * h[0] + i[2] * h[2];
                    let o_z = 2.0 * ih * h[2] - i[2];
                    if ih <= 0.0 || o_z < 1e-6 || i[2] < 1e-6 {
                        continue;
                    }
                    // 2 (both halves of phi) x FRAC_PI_2 wt (phi's weight) x 4 (i.h) o_z sin^2 cos wx
                    weight.push(2.0 * FRAC_PI_2 * wt * 4.0 * ih * o_z * sh * sh * chh * wx);
                    incidence.push(k);
                    geometry.push(Geometry {
                        cos_i: i[2],
                        cos_o: o_z,
                        sin_i: i[0],
                        cos_d: ih,
                        tan2_h: tan_h * tan_h,
                        theta_h,
                        pair: nodes.len(),
                    });
                    nodes.push((theta_h, ih));
                }
            }
        }
        Quadrature { geometry, nodes, incidences: thetas, weight, incidence }
    }
}

/// What the layer adds at one parameter set: T per channel at the incidences, T_avg and d_eff.
#[derive(Clone, Debug)]
pub struct Layer {
    /// E_F per channel at the quadrature's incidences.
    pub e_f: [Vec<f64>; 3],
    /// T = max(1 - E_F, 0).
    pub t: [Vec<f64>; 3],
    pub t_avg: [f64; 3],
    pub d_eff: [f64; 3],
}

impl Layer {
    /// From the interface's parts at the quadrature (`parts`, with A per channel from sigma_s), the
    /// interface's index and the layer's albedo per channel.
    pub fn new(q: &Quadrature, parts: &Parts, sigma_s: f64, lambdas: &[f64; 3], ior: f64, diffuse: &[f64; 3]) -> Layer {
        let mut e_f = [0, 1, 2].map(|_| vec![0.0; q.incidences.len()]);
        for (n, g) in q.geometry.iter().enumerate() {
            let f = q.weight[n] * fresnel::dielectric(g.cos_d, ior);
            for ch in 0..3 {
                let a = crate::model::coherent(sigma_s, g.cos_d, lambdas[ch]);
                e_f[ch][q.incidence[n]] += f * (a * parts.spec[n] + (1.0 - a) * parts.diff[3 * n + ch]);
            }
        }
        let t = e_f.clone().map(|e| e.iter().map(|v| (1.0 - v).max(0.0)).collect::<Vec<f64>>());
        // T_avg = 2 int T cos sin dtheta, T linear in theta between incidences (Simpson on 64 points a cell).
        let t_avg = [0, 1, 2].map(|ch| {
            let tc = &t[ch];
            let (n, top) = (64 * (tc.len() - 1), theta_max());
            let h = FRAC_PI_2 / n as f64;
            let sum: f64 = (0..=n)
                .map(|j| {
                    let th = j as f64 * h;
                    let w = if j == 0 || j == n {
                        1.0
                    } else if j % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * interpolate(tc, th.min(top)) * th.cos() * th.sin()
                })
                .sum();
            2.0 * sum * h / 3.0
        });
        let d_eff = [0, 1, 2].map(|ch| {
            let r = 1.0 - t_avg[ch] / (ior * ior);
            diffuse[ch] * (1.0 - r) / (1.0 - diffuse[ch] * r)
        });
        Layer { e_f, t, t_avg, d_eff }
    }

    /// T at the cosine `mu` of channel `ch`.
    pub fn transmittance(&self, ch: usize, mu: f64) -> f64 {
        interpolate(&self.t[ch], mu.clamp(0.0, 1.0).acos())
    }

    /// The layer's term d_eff T(i) T(o) / (pi T_avg).
    pub fn diffuse(&self, ch: usize, cos_i: f64, cos_o: f64) -> f64 {
        self.d_eff[ch] * self.transmittance(ch, cos_i) * self.transmittance(ch, cos_o) / (PI * self.t_avg[ch])
    }
}

/// T at theta from its values at the incidences, linear in theta (clamped at the ends).
fn interpolate(t: &[f64], theta: f64) -> f64 {
    let last = (t.len() - 1) as f64;
    let f = (theta / theta_max() * last).clamp(0.0, last);
    let k = (f as usize).min(t.len() - 2);
    let w = f - k as f64;
    (1.0 - w) * t[k] + w * t[k + 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_2n_minus_1() {
        let q = gauss_legendre(24);
        for k in 0..48i32 {
            let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k + 1) as f64 };
            let got: f64 = q.iter().map(|(x, w)| w * x.powi(k)).sum();
            assert!((got - exact).abs() < 1e-13, "x^{k}: {got} vs {exact}");
        }
    }
}
