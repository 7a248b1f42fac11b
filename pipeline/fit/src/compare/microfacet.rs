//! The microfacet comparison models: a conductor coat over a Lambertian base. Per channel,
//!
//!   rho = F(cos theta_d; eta, k) D(theta_h) G2(wi, wo) / (4 cos_i cos_o) + kd / pi,
//!
//! F the exact unpolarised conductor Fresnel factor, G2 = 1 / (1 + Lambda(wi) + Lambda(wo)) (Smith's
//! height-correlated form), and
//! - `ggx_lambert`: Trowbridge-Reitz, D = alpha^2 / (pi cos^4 theta_h (alpha^2 + tan^2 theta_h)^2),
//!   Lambda = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2;
//! - `beckmann_lambert`: D = exp(-tan^2 theta_h / alpha^2) / (pi alpha^2 cos^4 theta_h),
//!   Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2, a = 1 / (alpha tan theta);
//! - `epd_lambert`: the two-scale model's own EPD (beta, p) and its G1, from the general tables
//!   (`GeneralTables::parts` without diffraction): the talk's 11-parameter "Exponential
//!   Distribution and Lambert".

use super::{Compared, Comparison, Fitted};
use crate::descent::{finish, scout, Descent};
use crate::fit::{Samples, REFINED};
use crate::model::{GeneralTables, Geometry, Parts, Surface};
use crate::params::{Range, ETA, K};
use crate::problem::{Data, STEP};
use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;
use special::Error;
use std::f64::consts::PI;
use twoscale_tables::fresnel;

/// GGX's and Beckmann's alpha: from a mirror-like lobe to a near-diffuse one.
pub const ALPHA: (f64, f64) = (1e-3, 2.0);

/// The lobe's parameters: alpha, or the EPD's beta and p.
pub fn lobe_names(model: Comparison) -> &'static [&'static str] {
    match model {
        Comparison::EpdLambert => &["beta", "p"],
        _ => &["alpha"],
    }
}

/// The fitted parameters: the lobe's, and eta, k and kd per channel.
pub fn parameters(model: Comparison) -> usize {
    lobe_names(model).len() + 9
}

/// A comparison model's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analytic {
    pub model: Comparison,
    /// alpha, or the EPD's (beta, p) (the second unused by GGX and Beckmann).
    pub lobe: [f64; 2],
    pub eta: [f64; 3],
    pub k: [f64; 3],
    /// The Lambertian albedo per channel (rho adds kd / pi).
    pub kd: [f64; 3],
}

/// The map between LM's unbounded x and the parameters, as `params::Coordinates` does it:
/// x = (the lobe's, eta, k and kd per channel).
#[derive(Clone, Copy)]
struct Layout {
    model: Comparison,
    lobe: [Range; 2],
}

impl Layout {
    fn new(model: Comparison, tables: &GeneralTables) -> Layout {
        let domain = tables.domain();
        let lobe = match model {
            Comparison::EpdLambert => [Range::Log(domain.beta.0, domain.beta.1), Range::Log(domain.p.0, domain.p.1)],
            // alpha's (the second unused)
            _ => [Range::Log(ALPHA.0, ALPHA.1); 2],
        };
        Layout { model, lobe }
    }

    fn lobes(&self) -> usize {
        lobe_names(self.model).len()
    }

    fn len(&self) -> usize {
        parameters(self.model)
    }

    /// The range of coordinate i.
    fn range(&self, i: usize) -> Range {
        let l = self.lobes();
        match i {
            _ if i < l => self.lobe[i],
            _ if i < l + 3 => Range::Log(ETA.0, ETA.1),
            _ if i < l + 6 => Range::Log(K.0, K.1),
            _ => Range::Linear(0.0, 1.0),
        }
    }

    fn params(&self, x: &[f64]) -> Analytic {
        let (l, v) = (self.lobes(), |i: usize| self.range(i).value(x[i]));
        let lobe = if l == 2 { [v(0), v(1)] } else { [v(0), 0.0] };
        Analytic {
            model: self.model,
            lobe,
            eta: [0, 1, 2].map(|ch| v(l + ch)),
            k: [0, 1, 2].map(|ch| v(l + 3 + ch)),
            kd: [0, 1, 2].map(|ch| v(l + 6 + ch)),
        }
    }

    fn x(&self, a: &Analytic) -> Vec<f64> {
        let values: Vec<f64> = a.lobe[..self.lobes()].iter().chain(&a.eta).chain(&a.k).chain(&a.kd).copied().collect();
        values.iter().enumerate().map(|(i, &v)| self.range(i).x(v)).collect()
    }
}

/// Smith's Lambda at the direction of cosine `cos` for GGX (`beckmann` false) or Beckmann.
fn smith_lambda(beckmann: bool, alpha: f64, cos: f64) -> f64 {
    let tan2 = (1.0 - cos * cos).max(0.0) / (cos * cos);
    if beckmann {
        if tan2 == 0.0 {
            return 0.0;
        }
        let a = 1.0 / (alpha * tan2.sqrt());
        0.5 * ((-a * a).exp() / (a * PI.sqrt()) - a.compl_error())
    } else {
        // (sqrt(1 + t) - 1) / 2 without the cancellation at small t
        let t = alpha * alpha * tan2;
        0.5 * t / ((1.0 + t).sqrt() + 1.0)
    }
}

/// D at the half vector of tan^2 theta_h = `tan2_h`, GGX's or Beckmann's.
fn ndf(beckmann: bool, alpha: f64, tan2_h: f64) -> f64 {
    let (a2, sec2) = (alpha * alpha, 1.0 + tan2_h);
    if beckmann {
        (-tan2_h / a2).exp() * sec2 * sec2 / (PI * a2)
    } else {
        a2 * sec2 * sec2 / (PI * (a2 + tan2_h).powi(2))
    }
}

/// D G2 / (4 cos_i cos_o) at every sample of `data`.
fn specular(tables: &GeneralTables, model: Comparison, lobe: [f64; 2], data: &Data) -> Vec<f64> {
    if model == Comparison::EpdLambert {
        let surface = Surface { beta: lobe[0], p: lobe[1], sigma_s: 0.0, b: 1.0, c: 2.0 };
        let mut parts = Parts::default();
        tables.parts(&surface, &[0.5; 3], &data.geometry, &data.nodes, &mut parts);
        return parts.spec;
    }
    let (beckmann, alpha) = (model == Comparison::BeckmannLambert, lobe[0]);
    data.geometry
        .par_iter()
        .map(|g: &Geometry| {
            let d = ndf(beckmann, alpha, g.tan2_h);
            let g2 = 1.0 / (1.0 + smith_lambda(beckmann, alpha, g.cos_i) + smith_lambda(beckmann, alpha, g.cos_o));
            d * g2 / (4.0 * g.cos_i * g.cos_o)
        })
        .collect()
}

/// F at every sample of `data` for channel ch's index, into `out[3 n + ch]`.
fn fresnel_at(data: &Data, eta: f64, k: f64, ch: usize, out: &mut [f64]) {
    out.par_chunks_mut(3).zip(&data.geometry).for_each(|(f, g)| f[ch] = fresnel::conductor(g.cos_d, eta, k));
}

/// The least-squares problem of a comparison model, with `problem::Problem`'s residuals.
struct AnalyticProblem<'a> {
    tables: &'a GeneralTables,
    data: &'a Data,
    layout: Layout,
    x: DVector<f64>,
    params: Analytic,
    /// D G2 / (4 cos_i cos_o) per sample, and F per sample and channel.
    spec: Vec<f64>,
    fresnel: Vec<f64>,
    evaluations: usize,
}

impl<'a> AnalyticProblem<'a> {
    fn new(tables: &'a GeneralTables, data: &'a Data, layout: Layout, start: &Analytic) -> AnalyticProblem<'a> {
        let x = DVector::from_vec(layout.x(start));
        let mut p = AnalyticProblem {
            tables,
            data,
            layout,
            params: layout.params(x.as_slice()),
            x: x.clone(),
            spec: Vec::new(),
            fresnel: vec![0.0; 3 * data.len()],
            evaluations: 0,
        };
        p.set_params(&x);
        p
    }

    /// rho at sample n and channel ch from its parts.
    fn rho(spec: f64, fresnel: f64, kd: f64) -> f64 {
        fresnel * spec + kd / PI
    }

    fn residual(&self, n: usize, ch: usize, rho: f64) -> f64 {
        self.data.residual(n, ch, rho)
    }

    fn residuals_of(&self, spec: &[f64], fresnel: &[f64], kd: &[f64; 3]) -> Vec<f64> {
        (0..3 * self.data.len())
            .into_par_iter()
            .map(|i| {
                let (n, ch) = (i / 3, i % 3);
                self.residual(n, ch, Self::rho(spec[n], fresnel[i], kd[ch]))
            })
            .collect()
    }

    /// rho at sample n and channel ch at the current parameters.
    fn rho_at(&self, n: usize, ch: usize) -> f64 {
        Self::rho(self.spec[n], self.fresnel[3 * n + ch], self.params.kd[ch])
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for AnalyticProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
        self.params = self.layout.params(x.as_slice());
        let a = self.params;
        self.spec = specular(self.tables, a.model, a.lobe, self.data);
        for ch in 0..3 {
            fresnel_at(self.data, a.eta[ch], a.k[ch], ch, &mut self.fresnel);
        }
        self.evaluations += 1;
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.residuals_of(&self.spec, &self.fresnel, &self.params.kd);
        r.iter().all(|v| v.is_finite()).then(|| DVector::from_vec(r))
    }

    /// Forward differences, recomputing only what a coordinate moves: the lobe's the specular part,
    /// a channel's eta or k that channel's F, kd nothing but the sum.
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let r0 = self.residuals_of(&self.spec, &self.fresnel, &self.params.kd);
        let (n, l) = (self.data.len(), self.layout.lobes());
        let mut jac = DMatrix::zeros(3 * n, self.layout.len());
        for col in 0..self.layout.len() {
            let mut x = self.x.clone();
            x[col] += STEP;
            let a = self.layout.params(x.as_slice());
            if col < l {
                let spec = specular(self.tables, a.model, a.lobe, self.data);
                let r = self.residuals_of(&spec, &self.fresnel, &a.kd);
                for (row, (a, b)) in r.iter().zip(&r0).enumerate() {
                    jac[(row, col)] = (a - b) / STEP;
                }
                continue;
            }
            let ch = (col - l) % 3;
            let column: Vec<f64> = (0..n)
                .into_par_iter()
                .map(|m| {
                    let g = &self.data.geometry[m];
                    let f = if col < l + 6 {
                        fresnel::conductor(g.cos_d, a.eta[ch], a.k[ch])
                    } else {
                        self.fresnel[3 * m + ch]
                    };
                    (self.residual(m, ch, Self::rho(self.spec[m], f, a.kd[ch])) - r0[3 * m + ch]) / STEP
                })
                .collect();
            for (m, v) in column.into_iter().enumerate() {
                jac[(3 * m + ch, col)] = v;
            }
        }
        jac.iter().all(|v| v.is_finite()).then_some(jac)
    }
}

impl Descent<Analytic> for AnalyticProblem<'_> {
    fn loss(&self) -> f64 {
        self.residuals_of(&self.spec, &self.fresnel, &self.params.kd).iter().map(|r| r * r).sum()
    }

    fn current(&self) -> Analytic {
        self.params
    }

    fn evaluations(&self) -> usize {
        self.evaluations
    }
}

/// rho per channel of a microfacet model at every direction pair of `data`.
pub fn analytic_rho(tables: &GeneralTables, data: &Data, a: &Analytic) -> Vec<[f64; 3]> {
    let problem = AnalyticProblem::new(tables, data, Layout::new(a.model, tables), a);
    (0..data.len()).into_par_iter().map(|n| [0, 1, 2].map(|ch| problem.rho_at(n, ch))).collect()
}

/// The starts: a grid of lobes, a metal-like index (F0 = 0.61, as the two-scale conductor's) and a
/// dark or a bright base.
fn starts(model: Comparison) -> Vec<Analytic> {
    let lobes: Vec<[f64; 2]> = match model {
        Comparison::EpdLambert => {
            [0.01, 0.03, 0.1, 0.3].iter().flat_map(|&beta| [0.4, 1.0, 2.0].map(|p| [beta, p])).collect()
        }
        _ => [0.01, 0.03, 0.1, 0.3, 0.6].map(|alpha| [alpha, 0.0]).to_vec(),
    };
    lobes
        .iter()
        .flat_map(|&lobe| [0.01, 0.2].map(|kd| Analytic { model, lobe, eta: [1.5; 3], k: [3.0; 3], kd: [kd; 3] }))
        .collect()
}

/// Fits the microfacet `model` to `samples` as `super::fit_comparison` says.
pub fn fit(tables: &GeneralTables, samples: &Samples, model: Comparison, log: impl Fn(&str)) -> Compared {
    let layout = Layout::new(model, tables);
    let on = |data| move |a: &Analytic| AnalyticProblem::new(tables, data, layout, a);
    let scouted = scout(starts(model), on(&samples.shared.scout), REFINED);
    log(&format!("scout fit on {} samples, loss {:.4e}", samples.shared.scout.len(), scouted.0.loss));
    let done = finish(scouted, on(&samples.shared.fit));
    let all = on(samples.all())(&done.params);
    super::compared(samples, done, Fitted::Microfacet, |n, ch| all.rho_at(n, ch), log)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// D and Lambda together against the identity every microfacet model meets (Heitz 2014, eq. 5):
    /// the visible normals' projected area is the direction's, G1(o) int D(m) <o, m>+ dm = cos theta_o,
    /// G1 = 1 / (1 + Lambda); at theta_o = 0 it is D's normalisation. A midpoint rule over the
    /// hemisphere of m.
    #[test]
    fn visible_normals_project_to_the_directions_area() {
        let (steps_theta, steps_phi) = (4000, 720);
        for beckmann in [false, true] {
            for alpha in [0.3, 0.6] {
                for theta_o in [0.0f64, 0.7, 1.3] {
                    let o = [theta_o.sin(), 0.0, theta_o.cos()];
                    let (h_theta, h_phi) = (PI / 2.0 / steps_theta as f64, 2.0 * PI / steps_phi as f64);
                    let mut sum = 0.0;
                    for i in 0..steps_theta {
                        let theta = (i as f64 + 0.5) * h_theta;
                        let (s, c) = theta.sin_cos();
                        let d = ndf(beckmann, alpha, (s / c).powi(2));
                        for j in 0..steps_phi {
                            let phi = (j as f64 + 0.5) * h_phi;
                            let dot = o[0] * s * phi.cos() + o[2] * c;
                            sum += d * dot.max(0.0) * s;
                        }
                    }
                    let g1 = 1.0 / (1.0 + smith_lambda(beckmann, alpha, theta_o.cos()));
                    let area = g1 * sum * h_theta * h_phi;
                    assert!(
                        (area - theta_o.cos()).abs() < 2e-5,
                        "beckmann {beckmann}, alpha {alpha}, theta_o {theta_o}: {area} against {}",
                        theta_o.cos()
                    );
                }
            }
        }
    }
}
