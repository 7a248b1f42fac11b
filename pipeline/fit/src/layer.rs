//! The layered models at any parameters (docs/maths.md sections 10 and 11): the two-scale interface
//! with the dielectric Fresnel factor F_eta over a Lambertian layer (plastic) or a scattering medium
//! (subsurface),
//!
//!   rho = F_eta(cos_d) rho_I + d_eff T(i) T(o) / (pi T_avg)     (plastic),   T(mu) = max(1 - E_F(mu), 0),
//!   E_F(mu) = int F_eta rho_I cos theta_o do,   T_avg = 2 int T mu dmu,
//!   d_eff = d (1 - r) / (1 - d r),   r = 1 - T_avg / eta^2;
//!   subsurface: Jensen et al.'s single-scattering term and the dipole's R_d (1 - alpha s_max) in d_eff's place.
//!
//! E_F is integrated over the half vector at incidences uniform in theta_i (read between them
//! cubically in theta): x = ln tan theta_h on nodes over [ln 1e-4, ln 1e3] (trapezoid; the integrand
//! decays doubly exponentially at both ends, beta >= 0.005), phi on Gauss-Legendre nodes over
//! [0, pi] (the integrand is even in phi), with
//! do = 4 (i.h) dh and dh = sin^2 theta_h cos theta_h dx dphi. The rule was chosen by comparing it
//! with the per-material `interface_albedo` tables (docs/fit.md). The direction pairs are fixed, so
//! the model's parts at them are computed like a MERL file's samples (`GeneralTables::parts`).

use crate::model::{Geometry, Parts};
use rayon::prelude::*;
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

    /// The scout stage's rule: 8 incidences x 48 x 8 (1,744 direction pairs, an eighth of the fit's
    /// rule, under the scout's 4,000 samples). Against the same tables: within 4.5e-3, 1.4e-2 at
    /// the last incidence, T_avg within 1.6e-3. It only ranks and refines starts; the fit's rule
    /// finishes them (synthetic.py's grey plastic, `--model auto`: 66 s -> 33 s, the same result).
    pub fn scout() -> Quadrature {
        Quadrature::new(8, 48, 8)
    }

    /// The rule a fitted material is rendered and judged with: 24 incidences x 200 x 24 (65,727 direction
    /// pairs: within 4.7e-4 of the interface_albedo tables, 1.7e-3 at the last incidence), computed once
    /// per material, not at every step of the fit.
    pub fn render() -> Quadrature {
        Quadrature::new(24, 200, 24)
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
                        dot_t: 0.0, // unused: E_F is the interface's alone
                        tan2_h: tan_h * tan_h,
                        pair: nodes.len(),
                    });
                    nodes.push((theta_h, ih));
                }
            }
        }
        Quadrature { geometry, nodes, incidences: thetas, weight, incidence }
    }
}

/// What lies under the interface (docs/maths.md sections 10 and 11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Beneath {
    /// A Lambertian layer of albedo `diffuse` per channel.
    Diffuse { diffuse: [f64; 3] },
    /// A scattering medium of reduced albedo `albedo` per channel and Henyey-Greenstein asymmetry g.
    Medium { albedo: [f64; 3], g: f64 },
}

/// What the layer adds at one parameter set: T per channel at the incidences, T_avg, the factor of
/// the term T(i) T(o) / (pi T_avg) (d_eff, or the medium's R_d (1 - alpha s_max)) and, under a
/// medium, the single-scattering term's constants.
#[derive(Clone, Debug)]
pub struct Layer {
    /// E_F per channel at the quadrature's incidences.
    pub e_f: [Vec<f64>; 3],
    /// T = max(1 - E_F, 0).
    pub t: [Vec<f64>; 3],
    pub t_avg: [f64; 3],
    /// d_eff (a diffuse layer) or R_d (1 - alpha s_max) (a medium).
    pub multiple: [f64; 3],
    ior: f64,
    /// A medium's single-scattering albedo alpha per channel and g.
    single: Option<([f64; 3], f64)>,
    /// A medium's s_max (0 over a diffuse layer).
    s_max: f64,
}

impl Layer {
    /// From the interface's parts at the quadrature (`parts`, with A per channel from sigma_s), the
    /// interface's index and what lies beneath; a medium's s_max is taken from `previous` where g
    /// and the index are its (a Jacobian column that moves neither; with single_max's cosines
    /// hoisted and its incidences in parallel, the marble's `--model auto`: 67 s -> 40 s).
    pub fn new(
        q: &Quadrature,
        parts: &Parts,
        sigma_s: f64,
        lambdas: &[f64; 3],
        ior: f64,
        beneath: &Beneath,
        previous: Option<&Layer>,
    ) -> Layer {
        let mut e_f = [0, 1, 2].map(|_| vec![0.0; q.incidences.len()]);
        for (n, g) in q.geometry.iter().enumerate() {
            let f = q.weight[n] * fresnel::dielectric(g.cos_d, ior);
            for ch in 0..3 {
                let a = crate::model::coherent(sigma_s, g.cos_d, lambdas[ch]);
                e_f[ch][q.incidence[n]] += f * (a * parts.spec[n] + (1.0 - a) * parts.diff[3 * n + ch]);
            }
        }
        let t = e_f.clone().map(|e| e.iter().map(|v| (1.0 - v).max(0.0)).collect::<Vec<f64>>());
        // T_avg = 1 - E_F_avg, E_F_avg = 2 int E_F cos sin dtheta (E_F unclamped, as section 10 has it),
        // Simpson on 64 points a cell, E_F read cubically between incidences.
        let t_avg = [0, 1, 2].map(|ch| {
            let e = &e_f[ch];
            let (n, top) = (64 * (e.len() - 1), theta_max());
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
                    w * interpolate(e, th.min(top)) * th.cos() * th.sin()
                })
                .sum();
            1.0 - 2.0 * sum * h / 3.0
        });
        // r = 1 - T_avg / eta^2, the interface's internal reflectance.
        let r = t_avg.map(|ta| 1.0 - ta / (ior * ior));
        let (multiple, single, s_max) = match *beneath {
            // d_eff = d (1 - r) / (1 - d r)
            Beneath::Diffuse { diffuse } => {
                ([0, 1, 2].map(|ch| diffuse[ch] * (1.0 - r[ch]) / (1.0 - diffuse[ch] * r[ch])), None, 0.0)
            }
            // R_d = (alpha'/2) (1 + exp(-(4/3) A s3)) exp(-s3), s3 = sqrt(3 (1 - alpha')), A = (1 + r)/(1 - r);
            // alpha = alpha' / (alpha' + (1 - alpha') (1 - g))
            Beneath::Medium { albedo, g } => {
                let s_max = match previous {
                    Some(l) if l.ior == ior && l.single.is_some_and(|(_, g0)| g0 == g) => l.s_max,
                    _ => single_max(g, ior),
                };
                let alpha = albedo.map(|a| a / (a + (1.0 - a) * (1.0 - g)));
                let multiple = [0, 1, 2].map(|ch| {
                    let (a, s3) = (albedo[ch], (3.0 * (1.0 - albedo[ch])).sqrt());
                    let big_a = (1.0 + r[ch]) / (1.0 - r[ch]);
                    0.5 * a * (1.0 + (-4.0 / 3.0 * big_a * s3).exp()) * (-s3).exp() * (1.0 - alpha[ch] * s_max)
                });
                (multiple, Some((alpha, g)), s_max)
            }
        };
        Layer { e_f, t, t_avg, multiple, ior, single, s_max }
    }

    /// The layer's terms at (wi, wo): multiple T(i) T(o) / (pi T_avg), and under a medium the single
    /// scattering alpha T(i) T(o) p_g(t_i . o'_up) / (eta^2 (mu_i' + mu_o')), with the directions
    /// refracted through the mean surface (mu' = sqrt(1 - (1 - mu^2)/eta^2), t_i . o'_up =
    /// -(i_x o_x + i_y o_y)/eta^2 - mu_i' mu_o').
    pub fn beneath(&self, ch: usize, g: &Geometry) -> f64 {
        let tt = self.transmittance(ch, g.cos_i) * self.transmittance(ch, g.cos_o);
        let mut f = self.multiple[ch] * tt / (PI * self.t_avg[ch]);
        if let Some((alpha, g_hg)) = self.single {
            let e2 = self.ior * self.ior;
            let refracted = |mu: f64| (1.0 - (1.0 - mu * mu) / e2).max(0.0).sqrt();
            let (mi, mo) = (refracted(g.cos_i), refracted(g.cos_o));
            let cos = -g.dot_t / e2 - mi * mo;
            f += alpha[ch] * tt * henyey_greenstein(cos, g_hg) / (e2 * (mi + mo));
        }
        f
    }

    /// T at the cosine `mu` of channel `ch`.
    pub fn transmittance(&self, ch: usize, mu: f64) -> f64 {
        interpolate(&self.t[ch], mu.clamp(0.0, 1.0).acos())
    }
}

/// p_g(cos Theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos Theta)^(3/2)).
fn henyey_greenstein(cos: f64, g: f64) -> f64 {
    let x = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * x * x.sqrt())
}

/// s_max = max over mu' in [sqrt(1 - 1/eta^2), 1] of s(mu') = int p_g(t . o') mu_o' / (mu' + mu_o') do'
/// (docs/maths.md section 11), t = (-sqrt(1 - mu'^2), 0, -mu'): on 17 mu' uniform in that range, each
/// by Gauss-Legendre in mu_o' (6 panels x 16) and phi over [0, pi] (doubled; 12 panels x 16, the
/// phase function's backward peak of width ~ 1 + g resolved for g >= -0.9). Within 1.8e-4 of the
/// builder's rule (`twoscale_generate::material::subsurface`, 65 incidences) over g in [-0.9, 0.9]
/// (tests/suite/fit); 2e-5 but at g = -0.9, the sharpest backward peak, where the two rules differ.
pub fn single_max(g: f64, eta: f64) -> f64 {
    let rule = |lo: f64, hi: f64, panels: usize| -> Vec<(f64, f64)> {
        let gl = gauss_legendre(16);
        let step = (hi - lo) / panels as f64;
        (0..panels)
            .flat_map(|k| {
                let mid = lo + (k as f64 + 0.5) * step;
                gl.iter().map(move |&(x, w)| (mid + 0.5 * step * x, 0.5 * step * w)).collect::<Vec<_>>()
            })
            .collect()
    };
    let mus = rule(0.0, 1.0, 6);
    let phis: Vec<(f64, f64)> = rule(0.0, PI, 12).into_iter().map(|(phi, w)| (phi.cos(), w)).collect();
    let mu_c = (1.0 - 1.0 / (eta * eta)).sqrt();
    (0..17)
        .into_par_iter()
        .map(|k| {
            let mu = mu_c + (1.0 - mu_c) * k as f64 / 16.0;
            let s_i = (1.0 - mu * mu).max(0.0).sqrt();
            let mut s = 0.0;
            for &(mo, wm) in &mus {
                let s_o = (1.0 - mo * mo).sqrt();
                let inner: f64 =
                    phis.iter().map(|&(cos_phi, wp)| wp * henyey_greenstein(-s_i * s_o * cos_phi - mu * mo, g)).sum();
                s += 2.0 * wm * inner * mo / (mu + mo);
            }
            s
        })
        .reduce(|| 0.0, f64::max)
}

/// A value at theta from its values at the incidences, cubic in theta (Catmull-Rom, the end cells
/// with the end node repeated; clamped beyond): E_F curves between 12 incidences more than a linear
/// read tolerates (T_avg against the test plastics' interface_albedo: 2.7e-3 linear, 6.9e-4 cubic).
fn interpolate(t: &[f64], theta: f64) -> f64 {
    let last = (t.len() - 1) as f64;
    let f = (theta / theta_max() * last).clamp(0.0, last);
    let k = (f as usize).min(t.len() - 2);
    let w = f - k as f64;
    let at = |j: isize| t[j.clamp(0, t.len() as isize - 1) as usize];
    let (p0, p1, p2, p3) = (at(k as isize - 1), at(k as isize), at(k as isize + 1), at(k as isize + 2));
    p1 + 0.5 * w * (p2 - p0 + w * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + w * (3.0 * (p1 - p2) + p3 - p0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// g = 0: s(mu) = (1 - mu ln(1 + 1/mu)) / 2 (Chandrasekhar's first-order half-space albedo), largest
    /// at the critical angle's mu.
    #[test]
    fn isotropic_single_scattering_has_its_closed_form() {
        for eta in [1.3f64, 1.5, 2.4] {
            let mu = (1.0 - 1.0 / (eta * eta)).sqrt();
            let exact = 0.5 * (1.0 - mu * (1.0 + 1.0 / mu).ln());
            assert!((single_max(0.0, eta) - exact).abs() < 1e-9, "eta {eta}: {} vs {exact}", single_max(0.0, eta));
        }
    }

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
