//! The two-scale BRDF of one material folder with F = 1, as the runtimes evaluate it
//! (docs/runtimes.md "eval", the C `twoscale_brdf_eval_parts`, lobe "exact"): every table
//! read by linear interpolation in its encoded coordinates, clamped to its range.

use crate::axis::{Axis, AxisEncoding};
use crate::derived::Derivation;
use crate::file::open_table;
use crate::vector_math::{exp, ln};
use anyhow::{bail, Context, Result};
use std::f64::consts::{FRAC_PI_2, LN_2, PI};
use std::path::Path;

/// D's exponent y^p past which the runtimes take exp(-y^p) as 0: e^-104 = 6.8e-46 rounds to 0 in
/// float32 (its smallest subnormal is 1.4e-45).
const D_CUT: f64 = 104.0;

/// An axis uniform in its encoding, read as a texture unit reads it.
#[derive(Clone, Debug)]
struct Grid {
    axis: Axis,
    e0: f64,
    inv_step: f64,
}

impl Grid {
    fn new(axis: &Axis) -> Result<Grid> {
        if !axis.is_uniform() || axis.len() < 2 {
            bail!("axis {} is not uniform in its encoding (not a per-material table)", axis.name);
        }
        let e = axis.encoded();
        Ok(Grid { axis: axis.clone(), e0: e[0], inv_step: (e.len() - 1) as f64 / (e[e.len() - 1] - e[0]) })
    }

    /// The cell i (nodes i, i + 1) of the encoded coordinate e, clamped, and the weight of node i + 1.
    #[inline(always)]
    fn cell(&self, e: f64) -> (usize, f64) {
        let n = self.axis.len();
        let f = ((e - self.e0) * self.inv_step).max(0.0).min((n - 1) as f64); // NaN -> 0
        let i = (f as usize).min(n - 2);
        (i, f - i as f64)
    }

    fn lerp(&self, data: &[f32], e: f64) -> f64 {
        let (i, t) = self.cell(e);
        (1.0 - t) * data[i] as f64 + t * data[i + 1] as f64
    }
}

/// Bilinear interpolation of data[a][b] (C order) at encoded (ea, eb).
#[inline(always)]
fn lerp2(a: &Grid, b: &Grid, data: &[f32], ea: f64, eb: f64) -> f64 {
    bilinear(data, b.axis.len(), a.cell(ea), b.cell(eb))
}

/// data[a][b] (C order, rows of nb) between the cells (i, ta) of a and (j, tb) of b.
#[inline(always)]
fn bilinear(data: &[f32], nb: usize, (i, ta): (usize, f64), (j, tb): (usize, f64)) -> f64 {
    let (r0, r1) = (&data[i * nb..], &data[(i + 1) * nb..]);
    (1.0 - ta) * ((1.0 - tb) * r0[j] as f64 + tb * r0[j + 1] as f64)
        + ta * ((1.0 - tb) * r1[j] as f64 + tb * r1[j + 1] as f64)
}

/// The diffraction tables: ln R over (s, B), ln C over (u, v_theta) with v_theta derived from (u, theta_h).
#[derive(Clone, Debug)]
struct Diffraction {
    kc_s: Grid,
    kc_b: Grid,
    ln_r: Vec<f32>,
    lobe_u: Grid,
    lobe_v: Grid,
    ln_c: Vec<f32>,
    angle: Derivation,
}

/// One material's BRDF (epd_g1, and kcorr_renorm and zh_lobe when it diffracts).
#[derive(Clone, Debug)]
pub struct MaterialBrdf {
    pub beta: f64,
    pub p: f64,
    pub sigma_s: f64,
    pub b: f64,
    pub c: f64,
    pub n_p: f64,
    /// y = tan^2 theta_h / beta^2 from which D is 0: y^p = D_CUT.
    d_cut: f64,
    g1_theta: Grid,
    g1: Vec<f32>,
    diffraction: Option<Diffraction>,
}

/// The wavelength-free factors of rho(i, o) (eval_parts without A, C and R).
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    /// clamp(i.h, 0, 1).
    pub cos_d: f64,
    /// theta_h.
    pub theta_h: f64,
    /// D G2 / (4 cos_i cos_o) (the specular part with A = 1).
    pub specular: f64,
    /// G2.
    pub g2: f64,
    /// sin theta_i.
    pub sin_i: f64,
}

impl MaterialBrdf {
    /// Opens the tables of the material folder `dir` (checksums verified).
    pub fn open(dir: &Path) -> Result<MaterialBrdf> {
        let (manifest, axes, values) = open_table(dir, "epd_g1")?;
        let section = manifest.material.context("epd_g1 has no material section (not a material folder)")?;
        let number = |k: &str| section[k].as_f64().with_context(|| format!("material section: no number {k}"));
        let (beta, p, sigma_s, n_p) = (number("beta")?, number("p")?, number("sigma_s")?, number("n_p")?);
        let diffracting = sigma_s > 0.0;
        let (b, c) = if diffracting { (number("b")?, number("c")?) } else { (0.0, 0.0) };
        if !matches!(axes[0].encoding, AxisEncoding::BoundedLogTan { .. }) {
            bail!("epd_g1's theta axis is not bounded_log_tan (not a material folder)");
        }
        let g1 = values[0].1.iter().copied().collect();
        let mut brdf = MaterialBrdf {
            beta,
            p,
            sigma_s,
            b,
            c,
            n_p,
            d_cut: D_CUT.powf(1.0 / p),
            g1_theta: Grid::new(&axes[0])?,
            g1,
            diffraction: None,
        };
        if diffracting {
            let (_, kc_axes, kc) = open_table(dir, "kcorr_renorm")?;
            let (lobe_manifest, lobe_axes, lobe) = open_table(dir, "zh_lobe")?;
            let angle = lobe_manifest.derived_axes.first().context("zh_lobe has no derived angle")?.derivation;
            if !matches!(angle, Derivation::MaterialLobeAngle { .. }) {
                bail!("zh_lobe's angle is not material_lobe_angle (not a material folder)");
            }
            brdf.diffraction = Some(Diffraction {
                kc_s: Grid::new(&kc_axes[0])?,
                kc_b: Grid::new(&kc_axes[1])?,
                ln_r: kc[0].1.iter().copied().collect(),
                lobe_u: Grid::new(&lobe_axes[0])?,
                lobe_v: Grid::new(&lobe_axes[1])?,
                ln_c: lobe[0].1.iter().copied().collect(),
                angle,
            });
        }
        Ok(brdf)
    }

    pub fn has_diffraction(&self) -> bool {
        self.diffraction.is_some()
    }

    /// G1 at the angle of sine s and cosine c: epd_g1's e = ln((tan + eps)/(1 + delta tan)) written
    /// ln((s + eps c)/(c + delta s)), finite at the horizon.
    pub fn g1(&self, s: f64, c: f64) -> f64 {
        let AxisEncoding::BoundedLogTan { eps, delta } = self.g1_theta.axis.encoding else {
            unreachable!("checked by open")
        };
        self.g1_theta.lerp(&self.g1, ((s + eps * c) / (c + delta * s)).ln())
    }

    /// A = exp(-(4 pi sigma_s cos_d / lambda)^2).
    pub fn coherent(&self, cos_d: f64, lambda: f64) -> f64 {
        (-(4.0 * PI * self.sigma_s * cos_d / lambda).powi(2)).exp()
    }

    /// ln R from kcorr_renorm at (sin theta_i, B) (its B axis is ln B).
    pub fn ln_r(&self, sin_i: f64, bb: f64) -> f64 {
        let d = self.diffraction.as_ref().expect("a diffracting material");
        lerp2(&d.kc_s, &d.kc_b, &d.ln_r, d.kc_s.axis.encoding.encode(sin_i), bb.ln())
    }

    /// ln C(theta_h; u) from zh_lobe (v_theta derived from (u, theta_h)).
    pub fn ln_c(&self, u: f64, theta_h: f64) -> f64 {
        let d = self.diffraction.as_ref().expect("a diffracting material");
        lerp2(&d.lobe_u, &d.lobe_v, &d.ln_c, d.lobe_u.axis.encoding.encode(u), d.angle.forward(theta_h, &[u]))
    }

    /// K's factor (c - 1) B^2 / (2 pi) N(p) / beta^2 without C / R.
    pub fn k_scale(&self, bb: f64) -> f64 {
        (self.c - 1.0) / (2.0 * PI) * self.n_p / (self.beta * self.beta) * bb * bb
    }

    /// The wavelength-free factors of rho(i, o); None when i or o is below the surface.
    pub fn pair(&self, wi: [f64; 3], wo: [f64; 3]) -> Option<Pair> {
        if !(wi[2] > 0.0 && wo[2] > 0.0) {
            return None;
        }
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let t2 = h[0] * h[0] + h[1] * h[1];
        let h2 = t2 + h[2] * h[2];
        let (sin_i, sin_o) = (wi[0].hypot(wi[1]), wo[0].hypot(wo[1]));
        let cos_d = ((wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / h2.sqrt()).clamp(0.0, 1.0);
        let (g1i, g1o) = (self.g1(sin_i, wi[2]), self.g1(sin_o, wo[2]));
        let e = g1i + g1o - g1i * g1o;
        let g2 = if e > 0.0 { g1i * g1o / e } else { 0.0 };
        // D = N(p)/beta^2 exp(-(tan^2 theta_h / beta^2)^p) / cos^4 theta_h
        let sec2 = h2 / (h[2] * h[2]);
        // exp(-y^p) is 0 where y^p >= 104 (e^-104 = 6.8e-46 rounds to 0 in float32), as the C and Mitsuba runtimes have it
        let y = t2 / (h[2] * h[2]) / (self.beta * self.beta);
        let d = if y < self.d_cut {
            self.n_p / (self.beta * self.beta) * (-y.powf(self.p)).exp() * sec2 * sec2
        } else {
            0.0
        };
        Some(Pair { cos_d, theta_h: t2.sqrt().atan2(h[2]), specular: d * g2 / (4.0 * wi[2] * wo[2]), g2, sin_i })
    }

    /// rho's two parts with F = 1 at lambda (micrometres): [A D G2 / (4 cos_i cos_o), (1 - A) G2 K].
    pub fn eval_parts(&self, wi: [f64; 3], wo: [f64; 3], lambda: f64) -> [f64; 2] {
        let Some(x) = self.pair(wi, wo) else { return [0.0, 0.0] };
        if self.diffraction.is_none() {
            return [x.specular, 0.0];
        }
        let bb = self.b / lambda;
        let a = self.coherent(x.cos_d, lambda);
        let k = self.k_scale(bb) * (self.ln_c(bb * x.cos_d, x.theta_h) - self.ln_r(x.sin_i, bb)).exp();
        [a * x.specular, (1.0 - a) * x.g2 * k]
    }
}

/// The wavelength-dependent constants of rho at one incidence, for `MaterialBrdf::wave_parts`.
#[derive(Clone, Debug)]
pub struct Waves {
    /// 4 pi sigma_s / lambda: A = exp(-(a_scale cos_d)^2).
    a_scale: Vec<f64>,
    /// B = b / lambda.
    bb: Vec<f64>,
    /// K's factor (`k_scale`).
    k: Vec<f64>,
    /// ln R(theta_i, B).
    ln_r_i: Vec<f64>,
    /// ln B's cell in kcorr_renorm.
    b_cell: Vec<(usize, f64)>,
}

/// rho's parts at one pair for every wavelength of a `Waves`: `s` = A D G2 / (4 cos_i cos_o),
/// `d` = (1 - A) G2 K, and `sym` = sqrt(R_i / R_o), which turns d into the reciprocal part.
#[derive(Clone, Debug, Default)]
pub struct WaveParts {
    pub s: Vec<f64>,
    pub d: Vec<f64>,
    pub sym: Vec<f64>,
    a: Vec<f64>,
    e_u: Vec<f64>,
    v: Vec<f64>,
    ln_c: Vec<f64>,
    ln_r_o: Vec<f64>,
}

impl MaterialBrdf {
    /// The constants of `wave_parts` at incidence sin theta_i for the wavelengths `lambdas` (micrometres).
    pub fn waves(&self, sin_i: f64, lambdas: &[f64]) -> Waves {
        let bb: Vec<f64> = lambdas.iter().map(|&l| self.b / l).collect();
        let Some(d) = &self.diffraction else {
            let zeros = vec![0.0; lambdas.len()];
            return Waves { a_scale: zeros.clone(), bb, k: zeros.clone(), ln_r_i: zeros, b_cell: vec![] };
        };
        Waves {
            a_scale: lambdas.iter().map(|&l| 4.0 * PI * self.sigma_s / l).collect(),
            k: bb.iter().map(|&b| self.k_scale(b)).collect(),
            ln_r_i: bb.iter().map(|&b| self.ln_r(sin_i, b)).collect(),
            b_cell: bb.iter().map(|&b| d.kc_b.cell(b.ln())).collect(),
            bb,
        }
    }

    /// `eval_parts` at the pair `x` (o at sin theta_o = `sin_o`) for every wavelength of `waves`, into `out`:
    /// the same reads, with this crate's `vector_math` ln and exp (within 1 ulp of libm's) in loops over the
    /// wavelengths that compile to SIMD code (the per-material albedo's quadrature spends its time here).
    pub fn wave_parts(&self, x: &Pair, sin_o: f64, waves: &Waves, out: &mut WaveParts) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked above).
            return unsafe { self.wave_parts_avx2(x, sin_o, waves, out) };
        }
        self.wave_parts_lanes(x, sin_o, waves, out)
    }

    /// `wave_parts_lanes` compiled for AVX2's 4 lanes of f64 instead of SSE2's 2. Every lane does the
    /// same IEEE operations in the same order (no FMA contraction), so the bits are the same (test below).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn wave_parts_avx2(&self, x: &Pair, sin_o: f64, waves: &Waves, out: &mut WaveParts) {
        self.wave_parts_lanes(x, sin_o, waves, out)
    }

    #[inline(always)]
    fn wave_parts_lanes(&self, x: &Pair, sin_o: f64, waves: &Waves, out: &mut WaveParts) {
        let n = waves.bb.len();
        for v in
            [&mut out.s, &mut out.d, &mut out.sym, &mut out.a, &mut out.e_u, &mut out.v, &mut out.ln_c, &mut out.ln_r_o]
        {
            v.resize(n, 0.0);
        }
        let Some(dif) = &self.diffraction else {
            out.s.fill(x.specular);
            out.d.fill(0.0);
            out.sym.fill(1.0);
            return;
        };
        let AxisEncoding::Log1pSq { scale } = dif.lobe_u.axis.encoding else { unreachable!("checked by open") };
        let Derivation::MaterialLobeAngle { edge_d, v_anchor: va, theta_cap } = dif.angle else {
            unreachable!("checked by open")
        };
        // A, zh_lobe's u encoded (ln(1 + (u/scale)^2)) and its derived angle v (`Derivation::forward`).
        let lanes = out.a.iter_mut().zip(out.e_u.iter_mut()).zip(out.v.iter_mut());
        for (((a, e_u), v), (&a_scale, &bb)) in lanes.zip(waves.a_scale.iter().zip(&waves.bb)) {
            let t = a_scale * x.cos_d;
            *a = exp(-(t * t));
            let u = bb * x.cos_d;
            let q = u / scale;
            *e_u = ln(1.0 + q * q);
            let ta = (1.0 / (1.0 + 4.0 * u * u) + edge_d * edge_d).sqrt().min(theta_cap);
            let r = x.theta_h / ta;
            // One ln for both branches: of 1 + r near the peak, of r beyond (a select, so the loop still vectorizes).
            let near = x.theta_h <= ta;
            let l = ln(if near { 1.0 + r } else { r });
            *v = if near { va * l / LN_2 } else { va + (1.0 - va) * l / ln(FRAC_PI_2 / ta) };
        }
        // The table reads (gathers): ln C at (e_u, v), ln R at (sin theta_o, B).
        let s_cell = dif.kc_s.cell(dif.kc_s.axis.encoding.encode(sin_o));
        for k in 0..n {
            out.ln_c[k] = lerp2(&dif.lobe_u, &dif.lobe_v, &dif.ln_c, out.e_u[k], out.v[k]);
            out.ln_r_o[k] = bilinear(&dif.ln_r, dif.kc_b.axis.len(), s_cell, waves.b_cell[k]);
        }
        let parts = out.s.iter_mut().zip(out.d.iter_mut()).zip(out.sym.iter_mut());
        let inputs = out.a.iter().zip(&out.ln_c).zip(&out.ln_r_o).zip(waves.k.iter().zip(&waves.ln_r_i));
        for (((s, d), sym), (((&a, &ln_c), &ln_r_o), (&k, &ln_r_i))) in parts.zip(inputs) {
            *s = a * x.specular;
            *d = (1.0 - a) * x.g2 * k * exp(ln_c - ln_r_i);
            *sym = exp(0.5 * (ln_r_i - ln_r_o));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diffracting material on small synthetic tables (the reads, not the physics, are under test).
    fn synthetic() -> MaterialBrdf {
        let table =
            |n: usize, seed: f32| (0..n).map(|i| (i as f32 * 0.37 + seed).sin() * 3.0 - 2.0).collect::<Vec<f32>>();
        let grid = |axis: Axis| Grid::new(&axis).unwrap();
        let theta = Axis::uniform("theta", AxisEncoding::BoundedLogTan { eps: 1e-3, delta: 1e-3 }, 0.0, 1.5, 33);
        MaterialBrdf {
            beta: 0.05,
            p: 1.2,
            sigma_s: 0.04,
            b: 2.0,
            c: 2.2,
            n_p: 0.4,
            d_cut: D_CUT.powf(1.0 / 1.2),
            g1: table(33, 0.0).iter().map(|x| 0.9 + 0.02 * x).collect(),
            g1_theta: grid(theta),
            diffraction: Some(Diffraction {
                kc_s: grid(Axis::uniform("s", AxisEncoding::LogGap { end: 1.0, eps: 1e-4 }, 0.0, 1.0, 17)),
                kc_b: grid(Axis::uniform("b", AxisEncoding::Log, 2.0, 6.0, 9)),
                ln_r: table(17 * 9, 0.5),
                lobe_u: grid(Axis::uniform("u", AxisEncoding::Log1pSq { scale: 0.5 }, 0.0, 6.0, 21)),
                lobe_v: grid(Axis::uniform("v", AxisEncoding::Linear, 0.0, 1.0, 25)),
                ln_c: table(21 * 25, 1.5),
                angle: Derivation::MaterialLobeAngle { edge_d: 0.08, v_anchor: 0.6, theta_cap: 1.2 },
            }),
        }
    }

    #[test]
    fn avx2_wave_parts_are_bit_identical_to_the_portable_ones() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let brdf = synthetic();
            let lambdas: Vec<f64> = (0..43).map(|k| 0.36 + 0.011 * k as f64).collect();
            let (mut a, mut b) = (WaveParts::default(), WaveParts::default());
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
            let mut compared = 0;
            for k in 0..400 {
                let (ti, to, phi) =
                    (1.5 * ((k * 7) % 400) as f64 / 400.0, 1.5 * ((k * 13) % 397) as f64 / 397.0, k as f64);
                let wi = [ti.sin(), 0.0, ti.cos()];
                let wo = [to.sin() * phi.cos(), to.sin() * phi.sin(), to.cos()];
                let Some(pair) = brdf.pair(wi, wo) else { continue };
                let waves = brdf.waves(ti.sin(), &lambdas);
                brdf.wave_parts_lanes(&pair, to.sin(), &waves, &mut a);
                // SAFETY: AVX2 is available (checked above).
                unsafe { brdf.wave_parts_avx2(&pair, to.sin(), &waves, &mut b) };
                assert_eq!((bits(&a.s), bits(&a.d), bits(&a.sym)), (bits(&b.s), bits(&b.d), bits(&b.sym)), "pair {k}");
                assert!(a.d.iter().any(|&d| d > 0.0), "pair {k}: no diffraction to compare");
                compared += 1;
            }
            assert!(compared > 300, "{compared} pairs");
        }
    }
}
