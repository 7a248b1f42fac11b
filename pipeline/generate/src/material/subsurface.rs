//! The subsurface model's single-scattering bound (docs/maths.md section 11): for a Henyey-Greenstein
//! phase function of asymmetry g under a smooth interface of index eta,
//!     s(mu') = int_{upper hemisphere} p_g(cos Theta) mu_o' / (mu' + mu_o') domega_o',
//! the share of the light refracted in at cos mu' that single scattering sends back up (per unit
//! single-scattering albedo, the interface's transmission left out), with cos Theta = t_i . o' between
//! the refracted incident direction t_i = (-sqrt(1 - mu'^2), 0, -mu') and o' = (sin cos phi, sin sin phi, mu_o').
//! `single_max` is its largest value over the refracted directions, mu' in [sqrt(1 - 1/eta^2), 1].

use crate::numerics::legendre::composite_rule;
use std::f64::consts::PI;

/// p_g(cos Theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos Theta)^(3/2)), normalised over the sphere.
pub fn henyey_greenstein(cos: f64, g: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5))
}

/// s(mu') by a Gauss-Legendre product: mu_o' in 16 panels x 8 nodes, phi in [0, pi] (doubled) in 16 panels
/// x 8 nodes (the phase function's backward peak, width ~ 1 + g, is resolved for g >= -0.9: tested).
pub fn single_share(mu: f64, g: f64) -> f64 {
    let panels = |lo: f64, hi: f64| (0..=16).map(|k| lo + (hi - lo) * k as f64 / 16.0).collect::<Vec<f64>>();
    let (mx, mw) = composite_rule(&panels(0.0, 1.0), 8);
    let (px, pw) = composite_rule(&panels(0.0, PI), 8);
    let s_i = (1.0 - mu * mu).max(0.0).sqrt();
    let mut s = 0.0;
    for (&mo, &wm) in mx.iter().zip(&mw) {
        let s_o = (1.0 - mo * mo).sqrt();
        for (&phi, &wp) in px.iter().zip(&pw) {
            let cos = -s_i * s_o * phi.cos() - mu * mo;
            s += 2.0 * wm * wp * henyey_greenstein(cos, g) * mo / (mu + mo);
        }
    }
    s
}

/// max s(mu') over mu' in [sqrt(1 - 1/eta^2), 1] (the refracted incidences), on 65 points uniform in mu'
/// (s falls with mu' for every g tested, so the first, the critical angle's, is the maximum).
pub fn single_max(g: f64, eta: f64) -> f64 {
    let mu_c = (1.0 - 1.0 / (eta * eta)).sqrt();
    (0..=64).map(|k| single_share(mu_c + (1.0 - mu_c) * k as f64 / 64.0, g)).fold(0.0, f64::max)
}

/// The formula `single_max` computes, for the material section.
pub const SINGLE_MAX_FORMULA: &str = "single_max = max over mu' in [sqrt(1 - 1/ior^2), 1] of int_{upper hemisphere} p_g(t_i . o') \
    mu_o' / (mu' + mu_o') domega_o' (docs/maths.md section 11; Henyey-Greenstein p_g, t_i the refracted incident direction)";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::legendre::gauss_legendre;

    #[test]
    fn isotropic_single_scattering_has_its_closed_form() {
        // g = 0: s(mu) = (1 - mu ln(1 + 1/mu)) / 2 (Chandrasekhar's first-order half-space albedo).
        for mu in [0.05f64, 0.3, 0.745, 1.0] {
            let exact = 0.5 * (1.0 - mu * (1.0 + 1.0 / mu).ln());
            assert!((single_share(mu, 0.0) - exact).abs() < 1e-9, "mu {mu}: {} vs {exact}", single_share(mu, 0.0));
        }
    }

    #[test]
    fn the_phase_function_is_normalised_and_the_rule_resolves_its_peak() {
        // int p_g over the sphere = 1, by a fine product in (cos, phi) with the peak at cos = 1.
        for g in [-0.9, -0.5, 0.0, 0.8] {
            let (x, w) = gauss_legendre(400);
            let total: f64 = x.iter().zip(&w).map(|(c, w)| 2.0 * PI * w * henyey_greenstein(*c, g)).sum();
            assert!((total - 1.0).abs() < 1e-6, "g {g}: {total}");
        }
        // The rule against a 4x finer one at the strongest backward peak.
        let fine = {
            let panels = |lo: f64, hi: f64| (0..=64).map(|k| lo + (hi - lo) * k as f64 / 64.0).collect::<Vec<f64>>();
            let (mx, mw) = composite_rule(&panels(0.0, 1.0), 8);
            let (px, pw) = composite_rule(&panels(0.0, PI), 8);
            let (mu, g) = (0.745f64, -0.9);
            let s_i = (1.0 - mu * mu).sqrt();
            let mut s = 0.0;
            for (&mo, &wm) in mx.iter().zip(&mw) {
                for (&phi, &wp) in px.iter().zip(&pw) {
                    let cos = -s_i * (1.0 - mo * mo).sqrt() * phi.cos() - mu * mo;
                    s += 2.0 * wm * wp * henyey_greenstein(cos, g) * mo / (mu + mo);
                }
            }
            s
        };
        assert!((single_share(0.745, -0.9) - fine).abs() < 1e-6 * fine, "{} vs {fine}", single_share(0.745, -0.9));
    }

    #[test]
    fn single_max_is_the_critical_angles_share() {
        for (g, eta) in [(0.0f64, 1.5f64), (0.8, 1.3), (-0.5, 1.4)] {
            let mu_c = (1.0 - 1.0 / (eta * eta)).sqrt();
            assert!((single_max(g, eta) - single_share(mu_c, g)).abs() < 1e-12, "g {g}, eta {eta}");
        }
    }
}
