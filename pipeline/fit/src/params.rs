//! The fitted parameters and the unbounded coordinates Levenberg-Marquardt moves.
//!
//! MINPACK's LM has no bounds, and the general tables hold beta, p, b and c only over their axes,
//! so each bounded parameter is a logistic function of its coordinate x, in the logarithm where the
//! range spans decades: v = lo (hi/lo)^sigma(x) (beta, p, b), v = lo + (hi - lo) sigma(x) (c, and a
//! layered model's ior in [1.01, 3], a medium's g in [-0.9, 0.9]), sigma(x) = 1/(1 + e^-x); a
//! plastic's diffuse albedo and a medium's reduced albedo are sigma(x). sigma_s, eta and k only
//! need to be positive, but are bounded the same way, in the logarithm (`SIGMA_S`, `ETA`, `K`):
//! with v = e^x, a coordinate that barely moves the model (k of a dielectric-like file, where F
//! hardly depends on k -> 0) was stepped to e^x = inf, and the fit stopped on non-finite residuals.

use crate::layer::Beneath;
use crate::model::{Domain, Surface};

/// What lies under the two-scale surface, with its parameters per colour channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Under {
    /// A conductor of complex index eta + i k (docs/maths.md section 7).
    Conductor { eta: [f64; 3], k: [f64; 3] },
    /// A dielectric interface of real index `ior` over a Lambertian layer or a scattering medium
    /// (docs/maths.md sections 10 and 11).
    Layered { ior: f64, beneath: Beneath },
}

/// The models `twoscale fit --model` takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    Conductor,
    Plastic,
    Subsurface,
}

impl Model {
    pub fn name(self) -> &'static str {
        match self {
            Model::Conductor => "conductor",
            Model::Plastic => "plastic",
            Model::Subsurface => "subsurface",
        }
    }
}

/// Everything a model takes: the surface, the channels' wavelengths (micrometres) and what lies under.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub surface: Surface,
    pub lambdas: [f64; 3],
    pub under: Under,
}

/// What a coordinate of x stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coordinate {
    Beta,
    P,
    SigmaS,
    B,
    C,
    Eta(usize),
    K(usize),
    Ior,
    Diffuse(usize),
    Albedo(usize),
    G,
}

/// A subsurface medium's Henyey-Greenstein asymmetry: a scene file's range for `g`.
pub const G: (f64, f64) = (-0.9, 0.9);

/// The interface's index: a scene file's range for `ior`.
pub const IOR: (f64, f64) = (1.01, 3.0);

/// The roughness sigma_s (micrometres): from where diffraction is below 1e-7 of the reflection
/// ((4 pi sigma_s / lambda)^2 at 0.45 um) to where none of it is coherent.
pub const SIGMA_S: (f64, f64) = (1e-5, 1.0);

/// A conductor's index eta + i k: wider than any metal's or semiconductor's in the visible (eta
/// 0.03-5, k 0-10); k's lower end makes F a dielectric's to 1e-10.
pub const ETA: (f64, f64) = (1e-3, 100.0);
pub const K: (f64, f64) = (1e-5, 100.0);

/// The map between x and the parameters.
#[derive(Clone, Debug)]
pub struct Coordinates {
    pub layout: Vec<Coordinate>,
    pub model: Model,
    beta: (f64, f64),
    p: (f64, f64),
    b: (f64, f64),
    c: (f64, f64),
    lambdas: [f64; 3],
}

fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// The inverse of sigmoid, kept finite at the ends.
fn logit(t: f64) -> f64 {
    let t = t.clamp(1e-9, 1.0 - 1e-9);
    (t / (1.0 - t)).ln()
}

fn log_range(x: f64, (lo, hi): (f64, f64)) -> f64 {
    (lo * (hi / lo).powf(sigmoid(x))).clamp(lo, hi)
}

fn log_range_inv(v: f64, (lo, hi): (f64, f64)) -> f64 {
    logit((v / lo).ln() / (hi / lo).ln())
}

fn linear_range(x: f64, (lo, hi): (f64, f64)) -> f64 {
    (lo + (hi - lo) * sigmoid(x)).clamp(lo, hi)
}

fn linear_range_inv(v: f64, (lo, hi): (f64, f64)) -> f64 {
    logit((v - lo) / (hi - lo))
}

impl Coordinates {
    /// With `diffraction` false, sigma_s is 0 and b, c are not fitted.
    pub fn new(domain: &Domain, lambdas: [f64; 3], model: Model, diffraction: bool) -> Coordinates {
        use Coordinate::*;
        let mut layout = vec![Beta, P];
        if diffraction {
            layout.extend([SigmaS, B, C]);
        }
        match model {
            Model::Conductor => (0..3).for_each(|ch| layout.extend([Eta(ch), K(ch)])),
            Model::Plastic => layout.extend([Ior, Diffuse(0), Diffuse(1), Diffuse(2)]),
            Model::Subsurface => layout.extend([Ior, Albedo(0), Albedo(1), Albedo(2), G]),
        }
        Coordinates { layout, model, beta: domain.beta, p: domain.p, b: domain.b(&lambdas), c: domain.c, lambdas }
    }

    pub fn diffraction(&self) -> bool {
        self.layout.contains(&Coordinate::SigmaS)
    }

    pub fn params(&self, x: &[f64]) -> Params {
        let mut s = Surface { beta: 0.0, p: 0.0, sigma_s: 0.0, b: 1.0, c: 2.0 };
        let mut under = match self.model {
            Model::Conductor => Under::Conductor { eta: [1.0; 3], k: [0.0; 3] },
            Model::Plastic => Under::Layered { ior: 1.5, beneath: Beneath::Diffuse { diffuse: [0.0; 3] } },
            Model::Subsurface => Under::Layered { ior: 1.5, beneath: Beneath::Medium { albedo: [0.0; 3], g: 0.0 } },
        };
        for (&coordinate, &v) in self.layout.iter().zip(x) {
            match (coordinate, &mut under) {
                (Coordinate::Beta, _) => s.beta = log_range(v, self.beta),
                (Coordinate::P, _) => s.p = log_range(v, self.p),
                (Coordinate::SigmaS, _) => s.sigma_s = log_range(v, SIGMA_S),
                (Coordinate::B, _) => s.b = log_range(v, self.b),
                (Coordinate::C, _) => s.c = linear_range(v, self.c),
                (Coordinate::Eta(ch), Under::Conductor { eta, .. }) => eta[ch] = log_range(v, ETA),
                (Coordinate::K(ch), Under::Conductor { k, .. }) => k[ch] = log_range(v, K),
                (Coordinate::Ior, Under::Layered { ior, .. }) => *ior = linear_range(v, IOR),
                (Coordinate::Diffuse(ch), Under::Layered { beneath: Beneath::Diffuse { diffuse }, .. }) => {
                    diffuse[ch] = sigmoid(v)
                }
                (Coordinate::Albedo(ch), Under::Layered { beneath: Beneath::Medium { albedo, .. }, .. }) => {
                    albedo[ch] = sigmoid(v)
                }
                (Coordinate::G, Under::Layered { beneath: Beneath::Medium { g, .. }, .. }) => *g = linear_range(v, G),
                _ => unreachable!("the layout is the model's"),
            }
        }
        Params { surface: s, lambdas: self.lambdas, under }
    }

    /// x of `p` (parameters outside the domain are pulled just inside it).
    pub fn x(&self, p: &Params) -> Vec<f64> {
        let s = &p.surface;
        self.layout
            .iter()
            .map(|&coordinate| match (coordinate, p.under) {
                (Coordinate::Beta, _) => log_range_inv(s.beta, self.beta),
                (Coordinate::P, _) => log_range_inv(s.p, self.p),
                (Coordinate::SigmaS, _) => log_range_inv(s.sigma_s, SIGMA_S),
                (Coordinate::B, _) => log_range_inv(s.b, self.b),
                (Coordinate::C, _) => linear_range_inv(s.c, self.c),
                (Coordinate::Eta(ch), Under::Conductor { eta, .. }) => log_range_inv(eta[ch], ETA),
                (Coordinate::K(ch), Under::Conductor { k, .. }) => log_range_inv(k[ch], K),
                (Coordinate::Ior, Under::Layered { ior, .. }) => linear_range_inv(ior, IOR),
                (Coordinate::Diffuse(ch), Under::Layered { beneath: Beneath::Diffuse { diffuse }, .. }) => {
                    logit(diffuse[ch])
                }
                (Coordinate::Albedo(ch), Under::Layered { beneath: Beneath::Medium { albedo, .. }, .. }) => {
                    logit(albedo[ch])
                }
                (Coordinate::G, Under::Layered { beneath: Beneath::Medium { g, .. }, .. }) => linear_range_inv(g, G),
                _ => unreachable!("the parameters are the model's"),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_round_trip_through_x_and_stay_in_the_domain() {
        let domain =
            Domain { beta: (0.005, 0.5), p: (0.2, 5.0), c: (1.02, 3.02), b_over_lambda: (0.1, 1000.0), u_max: 100.0 };
        let lambdas = [0.65, 0.55, 0.45];
        let coords = Coordinates::new(&domain, lambdas, Model::Conductor, true);
        assert_eq!(domain.b(&lambdas), (0.1 * 0.65, 100.0 * 0.45));
        let surface = Surface { beta: 0.02, p: 0.3, sigma_s: 0.03, b: 1.5, c: 2.9 };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        let conductor = Under::Conductor { eta: [1.6, 1.5, 1.4], k: [3.0, 4.0, 5.0] };
        let plastic = Under::Layered { ior: 1.49, beneath: Beneath::Diffuse { diffuse: [0.1, 0.5, 0.9] } };
        let medium = Under::Layered { ior: 1.7, beneath: Beneath::Medium { albedo: [0.2, 0.95, 0.999], g: -0.4 } };
        for (model, under) in [(Model::Conductor, conductor), (Model::Plastic, plastic), (Model::Subsurface, medium)] {
            let coords = Coordinates::new(&domain, lambdas, model, true);
            let p = Params { surface, lambdas, under };
            let back = coords.params(&coords.x(&p));
            let (s, t) = (back.surface, p.surface);
            assert!(close(s.beta, t.beta) && close(s.p, t.p) && close(s.sigma_s, t.sigma_s), "{s:?}");
            assert!(close(s.b, t.b) && close(s.c, t.c), "{s:?}");
            match (back.under, under) {
                (Under::Conductor { eta, k }, Under::Conductor { eta: e, k: kk }) => {
                    assert!((0..3).all(|ch| close(eta[ch], e[ch]) && close(k[ch], kk[ch])))
                }
                (
                    Under::Layered { ior, beneath: Beneath::Diffuse { diffuse } },
                    Under::Layered { ior: i, beneath: Beneath::Diffuse { diffuse: d } },
                ) => {
                    assert!(close(ior, i) && (0..3).all(|ch| close(diffuse[ch], d[ch])))
                }
                (
                    Under::Layered { ior, beneath: Beneath::Medium { albedo, g } },
                    Under::Layered { ior: i, beneath: Beneath::Medium { albedo: a, g: gg } },
                ) => {
                    assert!(close(ior, i) && close(g, gg) && (0..3).all(|ch| (albedo[ch] - a[ch]).abs() < 1e-9))
                }
                _ => panic!("the model changed"),
            }
        }
        // Every coordinate, however far LM steps it, gives a parameter within its range.
        for x in [-1e4, -40.0, -3.0, 0.0, 3.0, 40.0, 1e4] {
            let p = coords.params(&vec![x; coords.layout.len()]);
            let s = p.surface;
            assert!((0.005..=0.5).contains(&s.beta) && (0.2..=5.0).contains(&s.p), "{s:?}");
            assert!((0.065..=45.0).contains(&s.b) && (1.02..=3.02).contains(&s.c), "{s:?}");
            assert!((SIGMA_S.0..=SIGMA_S.1).contains(&s.sigma_s), "{s:?}");
            let Under::Conductor { eta, k } = p.under else { panic!("a conductor") };
            assert!(
                eta.iter().all(|v| (ETA.0..=ETA.1).contains(v)) && k.iter().all(|v| (K.0..=K.1).contains(v)),
                "{p:?}"
            );
        }
        assert_eq!(Coordinates::new(&domain, lambdas, Model::Conductor, false).layout.len(), 8);
        assert_eq!(Coordinates::new(&domain, lambdas, Model::Plastic, true).layout.len(), 9);
    }
}
