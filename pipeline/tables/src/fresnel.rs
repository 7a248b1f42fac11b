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

/// Reflectance of a conductor of complex index eta + i k at the cosine `cos` (the C runtime's
/// `twoscale_fresnel_eval`): with a^2 + b^2 = |n^2 - sin^2|, a = Re sqrt(n^2 - sin^2),
///     r_s = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos),
///     F = (r_s + r_p)/2 = r_s t3 / (t3 + t4),  t3 = (a^2 + b^2) cos^2 + sin^4,  t4 = 2 a cos sin^2.
pub fn conductor(cos: f64, eta: f64, k: f64) -> f64 {
    let c2 = cos * cos;
    let s2 = 1.0 - c2;
    let t1 = eta * eta - k * k - s2;
    let ab = (t1 * t1 + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (ab + t1)).max(0.0).sqrt();
    let t3 = ab * c2 + s2 * s2;
    (ab + c2 - 2.0 * cos * a) * t3 / ((ab + c2 + 2.0 * cos * a) * (t3 + 2.0 * cos * a * s2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |r_s|^2 and |r_p|^2 from the complex amplitudes (an independent form), n = eta + i k.
    fn conductor_from_amplitudes(cos_i: f64, eta: f64, k: f64) -> f64 {
        type C = (f64, f64);
        let mul = |a: C, b: C| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: C, b: C| {
            let d = b.0 * b.0 + b.1 * b.1;
            ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
        };
        let sqrt = |a: C| {
            let r = a.0.hypot(a.1);
            let re = (0.5 * (r + a.0)).sqrt();
            (re, if re > 0.0 { a.1 / (2.0 * re) } else { (0.5 * (r - a.0)).sqrt() })
        };
        let n2 = mul((eta, k), (eta, k));
        let root = sqrt((n2.0 - (1.0 - cos_i * cos_i), n2.1));
        let rs = div((cos_i - root.0, -root.1), (cos_i + root.0, root.1));
        let (pc, pr) = ((n2.0 * cos_i, n2.1 * cos_i), root);
        let rp = div((pc.0 - pr.0, pc.1 - pr.1), (pc.0 + pr.0, pc.1 + pr.1));
        0.5 * (rs.0 * rs.0 + rs.1 * rs.1 + rp.0 * rp.0 + rp.1 * rp.1)
    }

    #[test]
    fn the_conductor_matches_its_complex_amplitudes() {
        for (eta, k) in [(1.6, 3.2), (0.2, 3.5), (1.5, 0.0), (2.9, 0.4), (0.05, 1.0)] {
            let f0 = ((eta - 1.0f64).powi(2) + k * k) / ((eta + 1.0f64).powi(2) + k * k);
            assert!((conductor(1.0, eta, k) - f0).abs() < 1e-14, "normal incidence at {eta} {k}");
            for i in 0..=100 {
                let c = i as f64 / 100.0;
                let (a, b) = (conductor(c, eta, k), conductor_from_amplitudes(c, eta, k));
                assert!((a - b).abs() < 1e-12, "eta {eta}, k {k}, cos {c}: {a} vs {b}");
            }
            assert!((conductor(0.0, eta, k) - 1.0).abs() < 1e-14, "grazing at {eta} {k}");
        }
    }

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
