//! The fitted parameters and the unbounded coordinates Levenberg-Marquardt moves.
//!
//! MINPACK's LM has no bounds, and the general tables hold beta, p, b and c only over their axes,
//! so each bounded parameter is a logistic function of its coordinate x, in the logarithm where the
//! range spans decades: v = lo (hi/lo)^sigma(x) (beta, p, b), v = lo + (hi - lo) sigma(x) (c, and a
//! layered model's ior in [1.01, 10], a medium's g in [-0.9, 0.9]), sigma(x) = 1/(1 + e^-x); a
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

    /// The fitted parameters: beta and p, sigma_s, b and c with diffraction, and what lies under
    /// (a conductor's eta and k per channel, a plastic's ior and diffuse albedo per channel, a
    /// medium's ior, albedo per channel and g).
    pub fn parameters(self, diffraction: bool) -> usize {
        let under = match self {
            Model::Conductor => 6,
            Model::Plastic => 4,
            Model::Subsurface => 5,
        };
        2 + if diffraction { 3 } else { 0 } + under
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

/// The interface's index: a scene file's range for `ior` (up to F0 = 0.67: a plastic capped at 3,
/// F0 0.25, fitted to a metal's coat of F0 0.6 overshot its grazing peak 2-3 times, docs/fit.md).
pub const IOR: (f64, f64) = (1.01, 10.0);

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

/// A parameter's range and scale: v = lo (hi/lo)^sigma(x) (`Log`) or lo + (hi - lo) sigma(x) (`Linear`).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Range {
    Log(f64, f64),
    Linear(f64, f64),
}

impl Range {
    /// Where v lies in the range, from 0 to 1, in its own scale.
    pub(crate) fn fraction(self, v: f64) -> f64 {
        match self {
            Range::Log(lo, hi) => (v / lo).ln() / (hi / lo).ln(),
            Range::Linear(lo, hi) => (v - lo) / (hi - lo),
        }
    }

    pub(crate) fn value(self, x: f64) -> f64 {
        match self {
            Range::Log(lo, hi) => (lo * (hi / lo).powf(sigmoid(x))).clamp(lo, hi),
            Range::Linear(lo, hi) => (lo + (hi - lo) * sigmoid(x)).clamp(lo, hi),
        }
    }

    pub(crate) fn x(self, v: f64) -> f64 {
        logit(self.fraction(v))
    }

    fn ends(self) -> (f64, f64) {
        match self {
            Range::Log(lo, hi) | Range::Linear(lo, hi) => (lo, hi),
        }
    }
}

/// A parameter this close to an end of its range (a fraction of the range, in its own scale) is
/// reported there: LM's logistic coordinate has all but stopped moving it (x beyond +-4.6), and
/// a file outside the model's family pins parameters at their ends.
const AT_END: f64 = 0.01;

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

impl Coordinate {
    pub fn name(self) -> String {
        match self {
            Coordinate::Beta => "beta".into(),
            Coordinate::P => "p".into(),
            Coordinate::SigmaS => "sigma_s".into(),
            Coordinate::B => "b".into(),
            Coordinate::C => "c".into(),
            Coordinate::Eta(ch) => format!("eta[{}]", CHANNELS[ch]),
            Coordinate::K(ch) => format!("k[{}]", CHANNELS[ch]),
            Coordinate::Ior => "ior".into(),
            Coordinate::Diffuse(ch) => format!("diffuse[{}]", CHANNELS[ch]),
            Coordinate::Albedo(ch) => format!("albedo[{}]", CHANNELS[ch]),
            Coordinate::G => "g".into(),
        }
    }
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

    fn range(&self, coordinate: Coordinate) -> Range {
        let log = |(lo, hi): (f64, f64)| Range::Log(lo, hi);
        let linear = |(lo, hi): (f64, f64)| Range::Linear(lo, hi);
        match coordinate {
            Coordinate::Beta => log(self.beta),
            Coordinate::P => log(self.p),
            Coordinate::SigmaS => log(SIGMA_S),
            Coordinate::B => log(self.b),
            Coordinate::C => linear(self.c),
            Coordinate::Eta(_) => log(ETA),
            Coordinate::K(_) => log(K),
            Coordinate::Ior => linear(IOR),
            Coordinate::Diffuse(_) | Coordinate::Albedo(_) => linear((0.0, 1.0)),
            Coordinate::G => linear(G),
        }
    }

    /// The parameter `coordinate` stands for in `p`.
    fn value(coordinate: Coordinate, p: &Params) -> f64 {
        let s = &p.surface;
        match (coordinate, p.under) {
            (Coordinate::Beta, _) => s.beta,
            (Coordinate::P, _) => s.p,
            (Coordinate::SigmaS, _) => s.sigma_s,
            (Coordinate::B, _) => s.b,
            (Coordinate::C, _) => s.c,
            (Coordinate::Eta(ch), Under::Conductor { eta, .. }) => eta[ch],
            (Coordinate::K(ch), Under::Conductor { k, .. }) => k[ch],
            (Coordinate::Ior, Under::Layered { ior, .. }) => ior,
            (Coordinate::Diffuse(ch), Under::Layered { beneath: Beneath::Diffuse { diffuse }, .. }) => diffuse[ch],
            (Coordinate::Albedo(ch), Under::Layered { beneath: Beneath::Medium { albedo, .. }, .. }) => albedo[ch],
            (Coordinate::G, Under::Layered { beneath: Beneath::Medium { g, .. }, .. }) => g,
            _ => unreachable!("the parameters are the model's"),
        }
    }

    pub fn params(&self, x: &[f64]) -> Params {
        let mut s = Surface { beta: 0.0, p: 0.0, sigma_s: 0.0, b: 1.0, c: 2.0 };
        let mut under = match self.model {
            Model::Conductor => Under::Conductor { eta: [1.0; 3], k: [0.0; 3] },
            Model::Plastic => Under::Layered { ior: 1.5, beneath: Beneath::Diffuse { diffuse: [0.0; 3] } },
            Model::Subsurface => Under::Layered { ior: 1.5, beneath: Beneath::Medium { albedo: [0.0; 3], g: 0.0 } },
        };
        for (&coordinate, &x) in self.layout.iter().zip(x) {
            let v = self.range(coordinate).value(x);
            match (coordinate, &mut under) {
                (Coordinate::Beta, _) => s.beta = v,
                (Coordinate::P, _) => s.p = v,
                (Coordinate::SigmaS, _) => s.sigma_s = v,
                (Coordinate::B, _) => s.b = v,
                (Coordinate::C, _) => s.c = v,
                (Coordinate::Eta(ch), Under::Conductor { eta, .. }) => eta[ch] = v,
                (Coordinate::K(ch), Under::Conductor { k, .. }) => k[ch] = v,
                (Coordinate::Ior, Under::Layered { ior, .. }) => *ior = v,
                (Coordinate::Diffuse(ch), Under::Layered { beneath: Beneath::Diffuse { diffuse }, .. }) => {
                    diffuse[ch] = v
                }
                (Coordinate::Albedo(ch), Under::Layered { beneath: Beneath::Medium { albedo, .. }, .. }) => {
                    albedo[ch] = v
                }
                (Coordinate::G, Under::Layered { beneath: Beneath::Medium { g, .. }, .. }) => *g = v,
                _ => unreachable!("the layout is the model's"),
            }
        }
        Params { surface: s, lambdas: self.lambdas, under }
    }

    /// x of `p` (parameters outside the domain are pulled just inside it).
    pub fn x(&self, p: &Params) -> Vec<f64> {
        self.layout.iter().map(|&c| self.range(c).x(Self::value(c, p))).collect()
    }

    /// The parameters of `p` within `AT_END` of an end of their range, as "name = value (lower
    /// end)": where a file outside the model's family pins them (a metal fitted as a plastic: ior
    /// 3, whose F0 = 0.25 is below a metal's; a diffuse base fitted by a conductor: b and c at
    /// their lower ends, the diffraction lobe standing in for it). b and c are left out where
    /// sigma_s is at its lower end: there they no longer move the model.
    pub fn at_ends(&self, p: &Params) -> Vec<AtBound> {
        let end = |c: Coordinate| {
            let (range, f) = (self.range(c), self.range(c).fraction(Self::value(c, p)));
            let (lo, hi) = range.ends();
            (f < AT_END).then_some(("lower", lo)).or((f > 1.0 - AT_END).then_some(("upper", hi)))
        };
        let inert = self.diffraction() && end(Coordinate::SigmaS).is_some_and(|e| e.0 == "lower");
        self.layout
            .iter()
            .filter(|&&c| !(inert && matches!(c, Coordinate::B | Coordinate::C)))
            .filter_map(|&c| {
                end(c).map(|(side, bound)| AtBound { name: c.name(), value: Self::value(c, p), bound, side })
            })
            .collect()
    }
}

/// A fitted parameter at an end of its range (`Coordinates::at_ends`): the JSON's `at_bounds`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AtBound {
    pub name: String,
    pub value: f64,
    pub bound: f64,
    #[serde(skip)]
    pub side: &'static str,
}

impl std::fmt::Display for AtBound {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{} = {} ({} end, {})", self.name, significant(self.value), self.side, significant(self.bound))
    }
}

/// v to 4 significant digits.
fn significant(v: f64) -> String {
    let digits = (3 - v.abs().max(1e-300).log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
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
        // A parameter within 1 % of its range's end, in its own scale, is reported there.
        let plastic = Coordinates::new(&domain, lambdas, Model::Plastic, true);
        let pinned = Params {
            surface: Surface { beta: 0.1, p: 0.6, sigma_s: 0.2, b: 0.065, c: 2.0 },
            lambdas,
            under: Under::Layered { ior: 9.95, beneath: Beneath::Diffuse { diffuse: [0.995, 0.5, 0.02] } },
        };
        let said = |p: &Params| plastic.at_ends(p).iter().map(|a| a.to_string()).collect::<Vec<_>>();
        assert_eq!(
            said(&pinned),
            [
                "b = 0.06500 (lower end, 0.06500)",
                "ior = 9.950 (upper end, 10.00)",
                "diffuse[red] = 0.9950 (upper end, 1.000)"
            ]
        );
        assert_eq!(
            plastic.at_ends(&pinned)[1],
            AtBound { name: "ior".into(), value: 9.95, bound: 10.0, side: "upper" }
        );
        // Without diffraction (sigma_s at its lower end), b and c do not matter and are not reported.
        let plain = Params { surface: Surface { sigma_s: 1.05e-5, ..pinned.surface }, ..pinned };
        assert_eq!(
            said(&plain),
            [
                "sigma_s = 0.00001050 (lower end, 0.00001000)",
                "ior = 9.950 (upper end, 10.00)",
                "diffuse[red] = 0.9950 (upper end, 1.000)"
            ]
        );
        for model in [Model::Conductor, Model::Plastic, Model::Subsurface] {
            for diffraction in [false, true] {
                let layout = Coordinates::new(&domain, lambdas, model, diffraction).layout;
                assert_eq!(layout.len(), model.parameters(diffraction));
            }
        }
    }
}
