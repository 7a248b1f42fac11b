//! K-correlation renormalisation R(s, B, c) (docs/maths.md section 3): the fraction of
//! the normalised K-correlation PSD inside the propagating disk
//! |g - (s, 0)| <= 1 (lambda = 1, B = b / lambda, s = sin theta_i).

use crate::numerics::legendre::gauss_legendre;
use crate::numerics::quadrature::{self, Integral};
use std::f64::consts::PI;

/// Relative tolerance on R of the ring quadrature (G7-based estimate, far
/// more pessimistic than the K15 result kept; see `tests` for the measured error).
pub const REL_TOL: f64 = 1e-11;

/// PSD mass outside the circle |g| = rho: (1 + B^2 rho^2)^((1-c)/2).
fn mass_outside(rho: f64, b: f64, c: f64) -> f64 {
    (0.5 * (1.0 - c) * (b * b * rho * rho).ln_1p()).exp()
}

/// PSD mass inside |g| = rho: 1 - (1 + B^2 rho^2)^((1-c)/2), with expm1/log1p
/// so that it stays accurate as c -> 1 and for small B rho.
pub fn mass_inside(rho: f64, b: f64, c: f64) -> f64 {
    -(0.5 * (1.0 - c) * (b * b * rho * rho).ln_1p()).exp_m1()
}

/// The ring part: (c-1) B^2 / pi int_{1-s}^{1+s} acos((f^2-1+s^2)/(2sf)) f (1+B^2 f^2)^(-(c+1)/2) df,
/// integrated over the angle psi of the disk's boundary point, f^2 = (1-s)^2 + 4 s sin^2(psi/2):
/// f df = s sin(psi) dpsi and the arc half-angle is atan2(sin psi, s - cos psi), which
/// removes the square-root behaviour at both ends of f. Two features set the
/// breakpoints (geometric from the narrower): the arc angle turns from pi to
/// pi/2 within psi ~ (1 - s), and the PSD peaks within psi ~ 1/B when B (1-s) < 1.
/// `floor`: absolute accuracy needed (the ring only has to be accurate relative to R).
fn ring(s: f64, b: f64, c: f64, rel_tol: f64, floor: f64) -> Integral {
    let breaks = ring_breaks(s, b);
    let scale = (c - 1.0) * b * b / PI;
    let r = quadrature::integrate(|psi| ring_integrand(psi, s, b, c), &breaks, rel_tol, floor / scale);
    Integral { value: scale * r.value, error: scale * r.error, ..r }
}

/// The ring's breakpoints in psi for PSD peaks as narrow as B's: 0, then geometric by 4 from the
/// narrower of the arc (1 - s) and PSD (1/B) scales, then pi.
fn ring_breaks(s: f64, b: f64) -> Vec<f64> {
    let mut breaks = vec![0.0];
    let mut x = ((1.0 - s).min(1.0 / b) / s.sqrt()).max(1e-9);
    while x < PI {
        breaks.push(x);
        x *= 4.0;
    }
    breaks.push(PI);
    breaks
}

/// The disk's boundary point at angle psi: (sin psi, cos psi, f^2 = (1-s)^2 + 4 s sin^2(psi/2)).
#[inline]
fn boundary(psi: f64, s: f64) -> (f64, f64, f64) {
    let (sin_psi, cos_psi) = psi.sin_cos();
    // 1 - cos(psi) without cancellation where cos(psi) > 0.
    let versine = if cos_psi > 0.0 { sin_psi * sin_psi / (1.0 + cos_psi) } else { 1.0 - cos_psi };
    (sin_psi, cos_psi, (1.0 - s) * (1.0 - s) + 2.0 * s * versine)
}

/// The ring's integrand in the boundary angle psi (see `ring`), without the factor (c-1) B^2 / pi.
#[inline]
pub fn ring_integrand(psi: f64, s: f64, b: f64, c: f64) -> f64 {
    let (sin_psi, cos_psi, f2) = boundary(psi, s);
    let psd = (-0.5 * (c + 1.0) * (b * b * f2).ln_1p()).exp();
    sin_psi.atan2(s - cos_psi) * psd * s * sin_psi
}

/// The table's rule: Gauss-Legendre nodes per panel of `renorm_row`'s ring, and the largest B the
/// tables hold (kcorr_renorm's axis end in both presets), which places the first breakpoint.
pub const ROW_NODES: usize = 20;
pub const ROW_B_MAX: f64 = 1000.0;

/// R(s, B, c) at every (B, c) of `bs` x `cs` (C order) for one s: the table's rule. The inner disk in
/// closed form and the ring skipped as in `renorm`; the ring by one composite Gauss-Legendre rule in
/// psi shared by every (B, c): `ring`'s breakpoints at the narrowest scale any B of the tables needs
/// (min(1 - s, 1 / ROW_B_MAX) / sqrt(s), then x4 up to pi), ROW_NODES nodes a panel. The geometry
/// (psi's arc angle and f^2) is computed once per s, ln(1 + B^2 f^2) once per B, and each c costs one
/// exp a node: 8-13 times faster than `renorm` node by node. Against `renorm` (adaptive, 1e-11) at every
/// node of both presets: 5.7e-13 relative at most, and the same f32 at every node
/// (tests/known_answers/kcorr.rs checks random points).
pub fn renorm_row(s: f64, bs: &[f64], cs: &[f64]) -> Vec<f64> {
    if s == 0.0 {
        return bs.iter().flat_map(|&b| cs.iter().map(move |&c| mass_inside(1.0, b, c))).collect();
    }
    let breaks = ring_breaks(s, ROW_B_MAX);
    // Per node: its weight times the arc angle and s sin(psi) (`ring_integrand` without the PSD), and f^2.
    let (gx, gw) = gauss_legendre(ROW_NODES);
    let (mut weight, mut f2) = (Vec::new(), Vec::new());
    for panel in breaks.windows(2) {
        let (mid, half) = (0.5 * (panel[0] + panel[1]), 0.5 * (panel[1] - panel[0]));
        for (g, w) in gx.iter().zip(&gw) {
            let (sin_psi, cos_psi, f2_psi) = boundary(mid + half * g, s);
            f2.push(f2_psi);
            weight.push(half * w * sin_psi.atan2(s - cos_psi) * s * sin_psi);
        }
    }
    let mut ln_psd = vec![0.0; f2.len()];
    let mut out = Vec::with_capacity(bs.len() * cs.len());
    for &b in bs {
        for (l, f2) in ln_psd.iter_mut().zip(&f2) {
            *l = (b * b * f2).ln_1p();
        }
        for &c in cs {
            let inner = mass_inside(1.0 - s, b, c);
            if mass_outside(1.0 - s, b, c) <= 1e-13 * inner {
                out.push(inner);
                continue;
            }
            let e = -0.5 * (c + 1.0);
            let sum: f64 = weight.iter().zip(&ln_psd).map(|(w, l)| w * (e * l).exp()).sum();
            out.push((inner + (c - 1.0) * b * b / PI * sum).min(1.0));
        }
    }
    out
}

/// R(s, B, c) in [0, 1].
pub fn renorm(s: f64, b: f64, c: f64) -> f64 {
    renorm_tol(s, b, c, REL_TOL)
}

/// `renorm` with the quadrature at relative tolerance `rel_tol` (for references).
pub fn renorm_tol(s: f64, b: f64, c: f64, rel_tol: f64) -> f64 {
    renorm_counted(s, b, c, rel_tol).0
}

/// `renorm_tol` and the number of ring-integrand evaluations it took (`twoscale bench`'s profile).
pub fn renorm_counted(s: f64, b: f64, c: f64, rel_tol: f64) -> (f64, usize) {
    let inner = mass_inside(1.0 - s, b, c);
    if s == 0.0 {
        return (inner, 0);
    }
    // 0 <= ring <= mass outside the inner circle: skip it when it cannot
    // change R beyond 1e-13 relative.
    if mass_outside(1.0 - s, b, c) <= 1e-13 * inner {
        return (inner, 0);
    }
    let ring = ring(s, b, c, rel_tol, rel_tol * inner);
    ((inner + ring.value).min(1.0), ring.evaluations)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_closed_form() {
        for &(b, c) in &[(0.1f64, 1.01f64), (1.0, 2.0), (37.0, 3.5), (1000.0, 101.0)] {
            // Naive closed form: its cancellation costs ~1e-16 absolute.
            let exact = 1.0 - (1.0 + b * b).powf((1.0 - c) / 2.0);
            let got = renorm(0.0, b, c);
            assert!((got - exact).abs() < 4e-16 + 1e-13 * exact, "B={b} c={c}: {got} vs {exact}");
        }
    }
}
