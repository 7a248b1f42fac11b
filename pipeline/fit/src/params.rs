//! The fitted parameters and the unbounded coordinates Levenberg-Marquardt moves.
//!
//! MINPACK's LM has no bounds, and the general tables hold beta, p, b and c only over their axes,
//! so each bounded parameter is a logistic function of its coordinate x, in the logarithm where the
//! range spans decades: v = lo (hi/lo)^sigma(x) (beta, p, b), v = lo + (hi - lo) sigma(x) (c),
//! sigma(x) = 1/(1 + e^-x). sigma_s, eta and k only need to be positive: v = e^x.

use crate::model::{Domain, Surface};

/// A colour channel: its wavelength (micrometres) and the conductor's complex index eta + i k there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    pub lambda: f64,
    pub eta: f64,
    pub k: f64,
}

/// Everything the conductor model takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub surface: Surface,
    pub channels: [Channel; 3],
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
}

/// The map between x and the parameters.
#[derive(Clone, Debug)]
pub struct Coordinates {
    pub layout: Vec<Coordinate>,
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

impl Coordinates {
    /// With `diffraction` false, sigma_s is 0 and b, c are not fitted.
    pub fn new(domain: &Domain, lambdas: [f64; 3], diffraction: bool) -> Coordinates {
        use Coordinate::*;
        let mut layout = vec![Beta, P];
        if diffraction {
            layout.extend([SigmaS, B, C]);
        }
        for ch in 0..3 {
            layout.extend([Eta(ch), K(ch)]);
        }
        Coordinates { layout, beta: domain.beta, p: domain.p, b: domain.b(&lambdas), c: domain.c, lambdas }
    }

    pub fn diffraction(&self) -> bool {
        self.layout.contains(&Coordinate::SigmaS)
    }

    pub fn params(&self, x: &[f64]) -> Params {
        let mut s = Surface { beta: 0.0, p: 0.0, sigma_s: 0.0, b: 1.0, c: 2.0 };
        let mut channels = self.lambdas.map(|lambda| Channel { lambda, eta: 1.0, k: 0.0 });
        for (&coordinate, &v) in self.layout.iter().zip(x) {
            match coordinate {
                Coordinate::Beta => s.beta = log_range(v, self.beta),
                Coordinate::P => s.p = log_range(v, self.p),
                Coordinate::SigmaS => s.sigma_s = v.exp(),
                Coordinate::B => s.b = log_range(v, self.b),
                Coordinate::C => s.c = (self.c.0 + (self.c.1 - self.c.0) * sigmoid(v)).clamp(self.c.0, self.c.1),
                Coordinate::Eta(ch) => channels[ch].eta = v.exp(),
                Coordinate::K(ch) => channels[ch].k = v.exp(),
            }
        }
        Params { surface: s, channels }
    }

    /// x of `p` (parameters outside the domain are pulled just inside it).
    pub fn x(&self, p: &Params) -> Vec<f64> {
        let s = &p.surface;
        self.layout
            .iter()
            .map(|&coordinate| match coordinate {
                Coordinate::Beta => log_range_inv(s.beta, self.beta),
                Coordinate::P => log_range_inv(s.p, self.p),
                Coordinate::SigmaS => s.sigma_s.max(1e-12).ln(),
                Coordinate::B => log_range_inv(s.b, self.b),
                Coordinate::C => logit((s.c - self.c.0) / (self.c.1 - self.c.0)),
                Coordinate::Eta(ch) => p.channels[ch].eta.max(1e-6).ln(),
                Coordinate::K(ch) => p.channels[ch].k.max(1e-6).ln(),
            })
            .collect()
    }

    /// The range of b the tables allow at the channels' wavelengths.
    pub fn b_range(&self) -> (f64, f64) {
        self.b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_round_trip_through_x_and_stay_in_the_domain() {
        let domain = Domain { beta: (0.005, 0.5), p: (0.2, 5.0), c: (1.02, 3.02), b_over_lambda: (0.1, 1000.0), u_max: 100.0 };
        let lambdas = [0.65, 0.55, 0.45];
        let coords = Coordinates::new(&domain, lambdas, true);
        assert_eq!(coords.b_range(), (0.1 * 0.65, 100.0 * 0.45));
        let p = Params {
            surface: Surface { beta: 0.02, p: 0.3, sigma_s: 0.03, b: 1.5, c: 2.9 },
            channels: [0, 1, 2].map(|ch| Channel { lambda: lambdas[ch], eta: 1.6 - 0.1 * ch as f64, k: 3.0 + ch as f64 }),
        };
        let back = coords.params(&coords.x(&p));
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        let (s, t) = (back.surface, p.surface);
        assert!(close(s.beta, t.beta) && close(s.p, t.p) && close(s.sigma_s, t.sigma_s), "{s:?}");
        assert!(close(s.b, t.b) && close(s.c, t.c), "{s:?}");
        assert!(back.channels.iter().zip(&p.channels).all(|(a, b)| close(a.eta, b.eta) && close(a.k, b.k)));
        for x in [-40.0, -3.0, 0.0, 3.0, 40.0] {
            let s = coords.params(&vec![x; coords.layout.len()]).surface;
            assert!((0.005..=0.5).contains(&s.beta) && (0.2..=5.0).contains(&s.p), "{s:?}");
            assert!((0.065..=45.0).contains(&s.b) && (1.02..=3.02).contains(&s.c), "{s:?}");
        }
        assert_eq!(Coordinates::new(&domain, lambdas, false).layout.len(), 8);
    }
}
