//! The least-squares problem Levenberg-Marquardt solves: one residual per sample and channel, the
//! loss's (`loss`), with a forward-difference Jacobian that recomputes only the parts a coordinate
//! moves (`model::Parts`).

use crate::layer::{Layer, Quadrature};
use crate::loss::{Loss, Scale};
use crate::model::{coherent, GeneralTables, Geometry, Parts};
use crate::params::{Coordinate, Coordinates, Params, Under};
use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;
use twoscale_tables::fresnel;

/// The forward-difference step in x (the coordinates are logarithms or logits: a relative step of
/// about 1e-3, well above the f32 tables' rounding and below the scale of their cells).
pub(crate) const STEP: f64 = 1e-3;

/// Samples as the problem uses them.
pub struct Data {
    pub geometry: Vec<Geometry>,
    /// Their lobe nodes (`measured::Measured::nodes`).
    pub nodes: Vec<(f64, f64)>,
    /// cos_i rho_measured, 3 per sample.
    pub value: Vec<f64>,
    /// The loss's g(cos_i rho_measured) (`loss::Scale::compress`), 3 per sample.
    pub target: Vec<f64>,
    /// The loss's weight w per sample.
    pub weight: Vec<f64>,
    pub scale: Scale,
}

impl Data {
    /// The samples of `geometry` and `nodes`, measured `rho`, each of weight w^2 = `weight` in the loss of
    /// `scale`.
    pub fn new(
        geometry: Vec<Geometry>,
        nodes: Vec<(f64, f64)>,
        rho: &[[f64; 3]],
        weight: &[f64],
        scale: Scale,
    ) -> Data {
        let value: Vec<f64> = geometry.iter().zip(rho).flat_map(|(g, r)| r.map(|v| g.cos_i * v)).collect();
        let target = value.iter().enumerate().map(|(i, &v)| scale.compress(v.max(0.0), i % 3)).collect();
        let weight = weight.iter().map(|w| w.sqrt()).collect();
        Data { geometry, nodes, value, target, weight, scale }
    }

    /// Directions only (no measurement): to evaluate a model at.
    pub fn directions(geometry: Vec<Geometry>, nodes: Vec<(f64, f64)>) -> Data {
        let n = geometry.len();
        Data::new(geometry, nodes, &vec![[0.0; 3]; n], &vec![1.0; n], Loss::LOW.scale(&[]))
    }

    /// The loss's residual at sample n and channel ch of a model's rho there.
    pub fn residual(&self, n: usize, ch: usize, rho: f64) -> f64 {
        let x = self.geometry[n].cos_i * rho;
        self.weight[n] * (self.scale.compress(x, ch) - self.target[3 * n + ch])
    }

    pub fn len(&self) -> usize {
        self.geometry.len()
    }

    pub fn is_empty(&self) -> bool {
        self.geometry.is_empty()
    }
}

/// A model's state at one parameter set: the surface's parts at the samples and, for a layered model,
/// the layer (from the parts at the interface-albedo quadrature).
#[derive(Clone, Default)]
pub struct State {
    pub parts: Parts,
    quadrature_parts: Parts,
    pub layer: Option<Layer>,
}

/// rho at sample n and channel ch: F (A S + (1 - A) G2 K), plus what lies beneath a layered model's interface.
pub fn rho(params: &Params, state: &State, g: &Geometry, n: usize, ch: usize) -> f64 {
    let a = coherent(params.surface.sigma_s, g.cos_d, params.lambdas[ch]);
    let interface = a * state.parts.spec[n] + (1.0 - a) * state.parts.diff[3 * n + ch];
    match params.under {
        Under::Conductor { eta, k } => fresnel::conductor(g.cos_d, eta[ch], k[ch]) * interface,
        Under::Layered { ior, .. } => {
            let layer = state.layer.as_ref().expect("a layered model's state has its layer");
            fresnel::dielectric(g.cos_d, ior) * interface + layer.beneath(ch, g)
        }
    }
}

/// What a change of parameters makes the model recompute.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Recompute {
    /// The surface's parts (`GeneralTables::parts` recomputes those the change moves).
    Parts,
    /// A, F or the layer's constants: closed forms over the same parts.
    Closed,
}

pub struct Problem<'a> {
    pub tables: &'a GeneralTables,
    pub data: &'a Data,
    pub quadrature: Option<&'a Quadrature>,
    pub coords: Coordinates,
    x: DVector<f64>,
    pub params: Params,
    state: State,
    /// Model evaluations by set_params.
    pub evaluations: usize,
}

impl<'a> Problem<'a> {
    /// A layered model needs `quadrature` (its interface albedo).
    pub fn new(
        tables: &'a GeneralTables,
        data: &'a Data,
        quadrature: Option<&'a Quadrature>,
        coords: Coordinates,
        start: &Params,
    ) -> Problem<'a> {
        let x = DVector::from_vec(coords.x(start));
        let params = coords.params(x.as_slice());
        let mut problem =
            Problem { tables, data, quadrature, coords, x, params, state: State::default(), evaluations: 0 };
        problem.set_params(&problem.x.clone());
        problem
    }

    /// The state at `p`, from `base` (the state at other parameters) recomputing only `what`.
    fn state_at(&self, p: &Params, base: &State, what: Recompute) -> State {
        let mut s = base.clone();
        if what != Recompute::Closed {
            self.tables.parts(&p.surface, &p.lambdas, &self.data.geometry, &self.data.nodes, &mut s.parts);
        }
        if let (Under::Layered { ior, beneath }, Some(q)) = (p.under, self.quadrature) {
            if what != Recompute::Closed || s.quadrature_parts.spec.is_empty() {
                self.tables.parts(&p.surface, &p.lambdas, &q.geometry, &q.nodes, &mut s.quadrature_parts);
            }
            let layer =
                Layer::new(q, &s.quadrature_parts, p.surface.sigma_s, &p.lambdas, ior, &beneath, base.layer.as_ref());
            s.layer = Some(layer);
        }
        s
    }

    fn residuals_of(&self, params: &Params, state: &State) -> Vec<f64> {
        let mut r = vec![0.0; self.data.target.len()];
        r.par_chunks_mut(3).enumerate().for_each(|(n, out)| {
            let g = &self.data.geometry[n];
            for ch in 0..3 {
                out[ch] = self.data.residual(n, ch, rho(params, state, g, n, ch));
            }
        });
        r
    }

    /// The model's state at the current parameters.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The sum of squared residuals at the current parameters.
    pub fn loss(&self) -> f64 {
        self.residuals_of(&self.params, &self.state).iter().map(|r| r * r).sum()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
        self.params = self.coords.params(x.as_slice());
        self.state = self.state_at(&self.params, &State::default(), Recompute::Parts);
        self.evaluations += 1;
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.residuals_of(&self.params, &self.state);
        r.iter().all(|v| v.is_finite()).then(|| DVector::from_vec(r))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let r0 = self.residuals_of(&self.params, &self.state);
        let mut jac = DMatrix::zeros(r0.len(), self.coords.layout.len());
        for (col, &coordinate) in self.coords.layout.iter().enumerate() {
            let mut x = self.x.clone();
            x[col] += STEP;
            let p = self.coords.params(x.as_slice());
            let what = match coordinate {
                Coordinate::Beta | Coordinate::P | Coordinate::B | Coordinate::C => Recompute::Parts,
                _ => Recompute::Closed,
            };
            let r = self.residuals_of(&p, &self.state_at(&p, &self.state, what));
            for (row, (a, b)) in r.iter().zip(&r0).enumerate() {
                jac[(row, col)] = (a - b) / STEP;
            }
        }
        jac.iter().all(|v| v.is_finite()).then_some(jac)
    }
}

impl crate::descent::Descent<Params> for Problem<'_> {
    fn loss(&self) -> f64 {
        Problem::loss(self)
    }

    fn current(&self) -> Params {
        self.params
    }

    fn evaluations(&self) -> usize {
        self.evaluations
    }
}
