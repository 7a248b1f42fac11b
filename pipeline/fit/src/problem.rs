//! The least-squares problem Levenberg-Marquardt solves: one residual per sample and channel,
//!
//!     r = ln(1 + cos_i rho_model) - ln(1 + cos_i rho_measured)
//!
//! (Löw et al. 2012's log metric, BBM's `lowLog`: the cosine-weighted BRDF, compressed by the
//! logarithm where it exceeds 1, so that a metal's specular peak does not drown its tails), with a
//! forward-difference Jacobian that recomputes only the parts a coordinate moves (`model::Parts`).

use crate::model::{coherent, GeneralTables, Geometry, Parts};
use crate::params::{Coordinate, Coordinates, Params};
use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;
use twoscale_tables::fresnel;

/// The forward-difference step in x (the coordinates are logarithms or logits: a relative step of
/// about 1e-3, well above the f32 tables' rounding and below the scale of their cells).
const STEP: f64 = 1e-3;

/// Samples as the problem uses them.
pub struct Data {
    pub geometry: Vec<Geometry>,
    /// ln(1 + cos_i rho_measured), 3 per sample.
    pub target: Vec<f64>,
}

impl Data {
    pub fn new(geometry: Vec<Geometry>, rho: &[[f64; 3]]) -> Data {
        let target = geometry.iter().zip(rho).flat_map(|(g, r)| r.map(|v| (g.cos_i * v).ln_1p())).collect();
        Data { geometry, target }
    }

    pub fn len(&self) -> usize {
        self.geometry.len()
    }

    pub fn is_empty(&self) -> bool {
        self.geometry.is_empty()
    }
}

/// rho at one sample and channel from its parts: F (A S + (1 - A) G2 K).
pub fn rho(params: &Params, parts: &Parts, g: &Geometry, n: usize, ch: usize) -> f64 {
    let c = &params.channels[ch];
    let a = coherent(params.surface.sigma_s, g.cos_d, c.lambda);
    fresnel::conductor(g.cos_d, c.eta, c.k) * (a * parts.spec[n] + (1.0 - a) * parts.diff[3 * n + ch])
}

pub struct Problem<'a> {
    pub tables: &'a GeneralTables,
    pub data: &'a Data,
    pub coords: Coordinates,
    x: DVector<f64>,
    pub params: Params,
    parts: Parts,
    /// Model evaluations (set_params and Jacobian columns that recompute parts).
    pub evaluations: usize,
}

impl<'a> Problem<'a> {
    pub fn new(tables: &'a GeneralTables, data: &'a Data, coords: Coordinates, start: &Params) -> Problem<'a> {
        let x = DVector::from_vec(coords.x(start));
        let mut problem =
            Problem { tables, data, params: coords.params(x.as_slice()), coords, x, parts: Parts::default(), evaluations: 0 };
        problem.set_params(&problem.x.clone());
        problem
    }

    fn lambdas(&self) -> [f64; 3] {
        self.params.channels.map(|c| c.lambda)
    }

    fn residuals_of(&self, params: &Params, parts: &Parts) -> Vec<f64> {
        let mut r = vec![0.0; self.data.target.len()];
        r.par_chunks_mut(3).enumerate().for_each(|(n, out)| {
            let g = &self.data.geometry[n];
            for ch in 0..3 {
                out[ch] = (g.cos_i * rho(params, parts, g, n, ch)).ln_1p() - self.data.target[3 * n + ch];
            }
        });
        r
    }

    /// The sum of squared residuals at the current parameters.
    pub fn loss(&self) -> f64 {
        self.residuals_of(&self.params, &self.parts).iter().map(|r| r * r).sum()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
        self.params = self.coords.params(x.as_slice());
        let lambdas = self.lambdas();
        self.tables.parts(&self.params.surface, &lambdas, &self.data.geometry, true, &mut self.parts);
        self.evaluations += 1;
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.residuals_of(&self.params, &self.parts);
        r.iter().all(|v| v.is_finite()).then(|| DVector::from_vec(r))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let r0 = self.residuals_of(&self.params, &self.parts);
        let mut jac = DMatrix::zeros(r0.len(), self.coords.layout.len());
        let lambdas = self.lambdas();
        for (col, &coordinate) in self.coords.layout.iter().enumerate() {
            let mut x = self.x.clone();
            x[col] += STEP;
            let p = self.coords.params(x.as_slice());
            let r = match coordinate {
                // D, G1 and C move: every part
                Coordinate::Beta | Coordinate::P => {
                    let mut parts = Parts::default();
                    self.tables.parts(&p.surface, &lambdas, &self.data.geometry, true, &mut parts);
                    self.residuals_of(&p, &parts)
                }
                // R and C move: the diffraction part only
                Coordinate::B | Coordinate::C => {
                    let mut parts = Parts { spec: self.parts.spec.clone(), diff: Vec::new() };
                    self.tables.parts(&p.surface, &lambdas, &self.data.geometry, false, &mut parts);
                    self.residuals_of(&p, &parts)
                }
                // A, or F: closed forms over the same parts
                Coordinate::SigmaS | Coordinate::Eta(_) | Coordinate::K(_) => self.residuals_of(&p, &self.parts),
            };
            for (row, (a, b)) in r.iter().zip(&r0).enumerate() {
                jac[(row, col)] = (a - b) / STEP;
            }
        }
        jac.iter().all(|v| v.is_finite()).then_some(jac)
    }
}
