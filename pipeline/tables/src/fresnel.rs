//! Fresnel reflectance of a smooth interface (docs/maths.md section 10), unpolarised.

/// Reflectance of a dielectric of real relative index `eta` (inside over outside) at the cosine `cos`
/// of the angle of incidence, from outside: with g^2 = eta^2 - 1 + cos^2,
///     F = 1/2 ((g - c)/(g + c))^2 (1 + ((c (g + c) - 1)/(c (g - c) + 1))^2)
/// (Walter et al. 2007, eq. 22); 1 where g^2 <= 0 (total internal reflection, eta < 1).
pub fn dielectric(cos: f64, eta: f64) -> f64 {
    let c = cos.abs();
    let g2 = eta * eta - 1.0 + c * c;
    if g2 <= 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    0.5 * a * a * (1.0 + b * b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// From the s and p amplitudes by Snell's law (an independent form).
    fn from_amplitudes(cos_i: f64, eta: f64) -> f64 {
        let sin_t = (1.0 - cos_i * cos_i).sqrt() / eta;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
        let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
        0.5 * (rs * rs + rp * rp)
    }

    #[test]
    fn matches_the_amplitudes_normal_incidence_and_grazing() {
        for eta in [1.1f64, 1.33, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((dielectric(1.0, eta) - r0).abs() < 1e-15, "normal incidence at {eta}");
            assert!((dielectric(0.0, eta) - 1.0).abs() < 1e-15, "grazing at {eta}");
            for k in 1..100 {
                let c = k as f64 / 100.0;
                let (a, b) = (dielectric(c, eta), from_amplitudes(c, eta));
                assert!((a - b).abs() < 1e-13, "eta {eta}, cos {c}: {a} vs {b}");
            }
        }
        assert_eq!(dielectric(0.3, 1.0 / 1.5), 1.0, "beyond the critical angle from inside");
    }
}
