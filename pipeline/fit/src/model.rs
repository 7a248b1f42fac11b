//! docs/maths.md section 7 at any parameters, from the general tables of a preset (`epd_g1`,
//! `epd_norm`, `kcorr_renorm`, `zh_lobe`), over the samples of a measured file:
//!
//!   rho = F(theta_d) [ A S + (1 - A) G2 K ],   S = D G2 / (4 cos_i cos_o),
//!   K = (c - 1) B^2 / (2 pi R(sin theta_i, B, c)) N(p)/beta^2 C(theta_h; B cos theta_d, c, p, beta).
//!
//! The parts are kept apart (`Parts`) because the fit perturbs one parameter at a time: sigma_s
//! moves only A, eta and k only F, b and c only the diffraction part. C depends on a direction pair
//! only through (theta_h, cos theta_d): each `Geometry` names its lobe node, and C is looked up once
//! per node and channel. A MERL sample's node is its (theta_h, theta_d) bin pair (at most 8,100 per
//! channel for about a million samples; `merl::lobe_nodes`).

use anyhow::{ensure, Context, Result};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;
use twoscale_tables::Lookup;

/// The general tables the model reads.
pub const TABLES: [&str; 4] = ["epd_g1", "epd_norm", "kcorr_renorm", "zh_lobe"];

/// The surface: the EPD (beta, p) and the K-correlation nano-geometry (sigma_s, b, c; lengths in
/// micrometres). sigma_s = 0: no diffraction part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub beta: f64,
    pub p: f64,
    pub sigma_s: f64,
    pub b: f64,
    pub c: f64,
}

/// Where the general tables hold the parameters (the zh_lobe and kcorr_renorm axes).
#[derive(Clone, Copy, Debug)]
pub struct Domain {
    pub beta: (f64, f64),
    pub p: (f64, f64),
    pub c: (f64, f64),
    /// B = b / lambda in kcorr_renorm.
    pub b_over_lambda: (f64, f64),
    /// u = B cos theta_d in zh_lobe (upper end).
    pub u_max: f64,
}

impl Domain {
    /// The range of b that keeps B and u in the tables at every wavelength of `lambdas`.
    pub fn b(&self, lambdas: &[f64]) -> (f64, f64) {
        let lo = lambdas.iter().fold(0.0f64, |m, &l| m.max(self.b_over_lambda.0 * l));
        let hi = lambdas.iter().fold(f64::INFINITY, |m, &l| m.min(self.u_max.min(self.b_over_lambda.1) * l));
        (lo, hi)
    }
}

/// One valid sample's geometry, computed once.
#[derive(Clone, Copy, Debug)]
pub struct Geometry {
    pub cos_i: f64,
    pub cos_o: f64,
    pub sin_i: f64,
    pub cos_d: f64,
    /// i_x o_x + i_y o_y (the subsurface model's refracted directions).
    pub dot_t: f64,
    /// tan^2 theta_h.
    pub tan2_h: f64,
    /// Its lobe node (theta_h, cos theta_d) in the list `parts` takes (`measured::Sample::node`).
    pub pair: usize,
}

impl Geometry {
    /// The geometry of the direction pair (wi, wo) (unit vectors, z the normal), whose lobe node is `pair`.
    pub fn of(wi: [f64; 3], wo: [f64; 3], pair: usize) -> Geometry {
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let norm2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        // cos^2 theta_h = h_z^2, cos theta_d = wi.h
        let hz2 = s[2] * s[2] / norm2;
        Geometry {
            cos_i: wi[2],
            cos_o: wo[2],
            sin_i: wi[0].hypot(wi[1]),
            cos_d: (wi[0] * s[0] + wi[1] * s[1] + wi[2] * s[2]) / norm2.sqrt(),
            dot_t: wi[0] * wo[0] + wi[1] * wo[1],
            tan2_h: (1.0 - hz2) / hz2,
            pair,
        }
    }
}

impl Geometry {
    /// A direction pair of this geometry: wi in the xz plane, wo where its cosines put it (y >= 0); an
    /// isotropic BRDF takes the same value at every rotation of the pair about the normal, and at its
    /// mirror image.
    pub fn directions(&self) -> ([f64; 3], [f64; 3]) {
        let wi = [self.sin_i, 0.0, self.cos_i];
        let sin_o2 = (1.0 - self.cos_o * self.cos_o).max(0.0);
        let x = if self.sin_i > 0.0 {
            (self.dot_t / self.sin_i).clamp(-sin_o2.sqrt(), sin_o2.sqrt())
        } else {
            sin_o2.sqrt()
        };
        (wi, [x, (sin_o2 - x * x).max(0.0).sqrt(), self.cos_o])
    }
}

/// The lobe node (theta_h, cos theta_d) of the direction pair (wi, wo).
pub fn lobe_node(wi: [f64; 3], wo: [f64; 3]) -> (f64, f64) {
    let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let norm = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    ((s[2] / norm).clamp(-1.0, 1.0).acos(), (wi[0] * s[0] + wi[1] * s[1] + wi[2] * s[2]) / norm)
}

/// rho's parts at every sample: `spec` = S (channel-free), `diff[3 n + ch]` = G2 K at channel ch;
/// and what they are made of, kept with the parameters it depends on, so that `parts` recomputes
/// only what a change of parameters moves (G2 and S depend on (beta, p), R on (b, c)).
#[derive(Clone, Debug, Default)]
pub struct Parts {
    pub spec: Vec<f64>,
    pub diff: Vec<f64>,
    g2: Vec<f64>,
    /// G2 and `spec` are those of this (beta, p) (`parts` is always called on one geometry per
    /// `Parts`: a problem's samples, or its quadrature's).
    microfacet_of: Option<(f64, f64)>,
    /// R(sin theta_i, b / lambda, c) per sample and channel.
    renorm: Vec<f64>,
    /// `renorm` is that of this (b, c, lambdas).
    renorm_of: Option<(f64, f64, [f64; 3])>,
}

/// The general tables, opened (checksums verified).
pub struct GeneralTables {
    g1: Lookup,
    norm: Lookup,
    kcorr: Lookup,
    lobe: Lookup,
}

/// exp(-y^p) is 0 past y^p = 104 (e^-104 rounds to 0 in float32), as the runtimes have it.
const D_CUT: f64 = 104.0;

impl GeneralTables {
    pub fn open(dir: &Path) -> Result<GeneralTables> {
        let open = |t: &str| Lookup::open(dir, t).with_context(|| format!("{}: general table {t}", dir.display()));
        let tables = GeneralTables {
            g1: open("epd_g1")?,
            norm: open("epd_norm")?,
            kcorr: open("kcorr_renorm")?,
            lobe: open("zh_lobe")?,
        };
        ensure!(tables.lobe.coordinates() == ["u", "c", "p", "beta", "theta_h"], "zh_lobe: unexpected coordinates");
        ensure!(tables.kcorr.coordinates() == ["s", "b_over_lambda", "c"], "kcorr_renorm: unexpected coordinates");
        ensure!(tables.g1.coordinates() == ["p", "a"], "epd_g1: unexpected coordinates");
        Ok(tables)
    }

    pub fn domain(&self) -> Domain {
        let lobe = &self.lobe.axes;
        let range = |a: &twoscale_tables::axis::Axis| (a.min(), a.max());
        let (kc_b, kc_c) = (range(&self.kcorr.axes[1]), range(&self.kcorr.axes[2]));
        let (lc, g1p) = (range(&lobe[1]), range(&self.g1.axes[0]));
        Domain {
            beta: range(&lobe[3]),
            p: (range(&lobe[2]).0.max(g1p.0), range(&lobe[2]).1.min(g1p.1)),
            c: (lc.0.max(kc_c.0), lc.1.min(kc_c.1)),
            b_over_lambda: kc_b,
            u_max: lobe[0].max(),
        }
    }

    fn value(table: &Lookup, point: &[f64]) -> f64 {
        table.decode_first(point).expect("a point inside the table (the fit keeps parameters in its domain)")
    }

    /// G1(p, beta tan theta) at the angle of sine s and cosine c.
    fn g1(&self, p: f64, beta: f64, s: f64, c: f64) -> f64 {
        Self::value(&self.g1, &[p, beta * s / c])
    }

    /// The parts at every direction pair of `geometry`, whose lobe nodes are `nodes`, for the
    /// channels' wavelengths `lambdas`. `out` holds the parts of the same geometry at other
    /// parameters (or none): S and G2 are recomputed only where beta or p moved, R where b or c did.
    pub fn parts(&self, m: &Surface, lambdas: &[f64; 3], geometry: &[Geometry], nodes: &[(f64, f64)], out: &mut Parts) {
        let n_p = Self::value(&self.norm, &[m.p]);
        let beta2 = m.beta * m.beta;
        let same_len = out.spec.len() == geometry.len();
        if !same_len || out.microfacet_of != Some((m.beta, m.p)) {
            let y_cut = D_CUT.powf(1.0 / m.p);
            out.spec.resize(geometry.len(), 0.0);
            out.g2.resize(geometry.len(), 0.0);
            out.spec.par_iter_mut().zip(out.g2.par_iter_mut()).zip(geometry).for_each(|((spec, g2), g)| {
                let sin_o = (1.0 - g.cos_o * g.cos_o).max(0.0).sqrt();
                let (g1i, g1o) = (self.g1(m.p, m.beta, g.sin_i, g.cos_i), self.g1(m.p, m.beta, sin_o, g.cos_o));
                let e = g1i + g1o - g1i * g1o;
                *g2 = if e > 0.0 { g1i * g1o / e } else { 0.0 };
                // D = N(p)/beta^2 exp(-(tan^2 theta_h / beta^2)^p) / cos^4 theta_h
                let y = g.tan2_h / beta2;
                let sec2 = 1.0 + g.tan2_h;
                let d = if y < y_cut { n_p / beta2 * (-y.powf(m.p)).exp() * sec2 * sec2 } else { 0.0 };
                *spec = d * *g2 / (4.0 * g.cos_i * g.cos_o);
            });
            out.microfacet_of = Some((m.beta, m.p));
        }
        out.diff.resize(3 * geometry.len(), 0.0);
        if m.sigma_s <= 0.0 {
            out.diff.fill(0.0);
            return;
        }
        if !same_len || out.renorm_of != Some((m.b, m.c, *lambdas)) {
            out.renorm.resize(3 * geometry.len(), 0.0);
            out.renorm.par_chunks_mut(3).zip(geometry).for_each(|(r, g)| {
                for ch in 0..3 {
                    r[ch] = Self::value(&self.kcorr, &[g.sin_i, m.b / lambdas[ch], m.c]);
                }
            });
            out.renorm_of = Some((m.b, m.c, *lambdas));
        }
        // C per lobe node and channel, for the nodes in use.
        let mut used = vec![false; nodes.len()];
        for g in geometry {
            used[g.pair] = true;
        }
        let mut lobe = vec![f64::NAN; nodes.len() * 3];
        lobe.par_chunks_mut(3).enumerate().filter(|(node, _)| used[*node]).for_each(|(node, out)| {
            let (theta_h, cos_d) = nodes[node];
            for (ch, v) in out.iter_mut().enumerate() {
                let u = m.b / lambdas[ch] * cos_d;
                *v = Self::value(&self.lobe, &[u, m.c, m.p, m.beta, theta_h]);
            }
        });
        let k_scale = lambdas.map(|l| (m.c - 1.0) / (2.0 * PI) * n_p / beta2 * (m.b / l).powi(2));
        let (g2, renorm) = (&out.g2, &out.renorm);
        out.diff.par_chunks_mut(3).enumerate().for_each(|(n, diff)| {
            let pair = geometry[n].pair;
            for ch in 0..3 {
                diff[ch] = g2[n] * k_scale[ch] * lobe[3 * pair + ch] / renorm[3 * n + ch];
            }
        });
    }
}

/// A = exp(-(4 pi sigma_s cos theta_d / lambda)^2).
pub fn coherent(sigma_s: f64, cos_d: f64, lambda: f64) -> f64 {
    (-(4.0 * PI * sigma_s * cos_d / lambda).powi(2)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair's geometry, back to directions and again, is the same geometry.
    #[test]
    fn a_geometrys_directions_have_that_geometry() {
        let unit = |v: [f64; 3]| {
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|x| x / n)
        };
        for (wi, wo) in [
            ([0.3, -0.2, 0.9], [-0.5, 0.4, 0.6]),
            ([0.0, 0.0, 1.0], [0.6, 0.0, 0.8]),
            ([-0.9, 0.1, 0.2], [0.1, 0.9, 0.3]),
        ] {
            let g = Geometry::of(unit(wi), unit(wo), 7);
            let (a, b) = g.directions();
            let h = Geometry::of(a, b, 7);
            for (x, y) in
                [(g.cos_i, h.cos_i), (g.cos_o, h.cos_o), (g.sin_i, h.sin_i), (g.cos_d, h.cos_d), (g.dot_t, h.dot_t)]
            {
                assert!((x - y).abs() < 1e-12, "{g:?} vs {h:?}");
            }
            assert!((g.tan2_h - h.tan2_h).abs() < 1e-12 * (1.0 + g.tan2_h));
        }
    }
}
