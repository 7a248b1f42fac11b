//! Table axes: node coordinates in physical units and the encoding in which
//! a renderer interpolates linearly between them.
//!
//! Every encoding is a strictly monotone map e(x) that is finite on the whole
//! axis (including the ends that reach 0 or +inf). A lookup finds the cell
//! i with e(x_i) <= e(x) <= e(x_i+1) (or the reverse for decreasing axes) and
//! interpolates with weight t = (e(x) - e(x_i)) / (e(x_i+1) - e(x_i)).

use serde::{Deserialize, Serialize};
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AxisEncoding {
    /// e = x.
    Linear,
    /// e = ln x.
    Log,
    /// e = 1/x.
    Reciprocal,
    /// e = exp(-x^(-1/k)): 0 at x = 0, 1 at x = +inf (the paper's a axis, k = 20).
    ExpNegPower { k: f64 },
    /// e = ln((x + eps) / (1 + delta x)), e(+inf) = -ln(delta): logarithmic
    /// between eps and 1/delta, finite at 0 and at +inf.
    BoundedLog { eps: f64, delta: f64 },
    /// e = 1/(x + shift) (the paper's b_over_lambda axis, shift = 10).
    ShiftedReciprocal { shift: f64 },
    /// e = ln(x - shift) (c - 1 on a log scale: shift = 1).
    ShiftedLog { shift: f64 },
    /// e = -ln(end + eps - x): logarithmic in the gap to `end`, finite at `end`
    /// (s = sin theta_i near grazing incidence).
    LogGap { end: f64, eps: f64 },
    /// e = ln(x) + ln(ln(1 + x^2)): ~3 ln x for small x, ~ln x + ln(2 ln x)
    /// for large x (B = b/lambda: the PSD mass inside radius 1 is a function of
    /// (c - 1) ln(1 + B^2)).
    LogPlusLogLog1pSq,
    /// e = ln(1 + (x/scale)^2): quadratic at 0, ~2 ln x for large x (u of
    /// zh_lobe: the K-correlation lobe depends on u through 4 u^2, scale = 1/2).
    Log1pSq { scale: f64 },
    /// e = ln((tan x + eps) / (1 + delta tan x)): `bounded_log` of tan x, for
    /// an angle x in [0, pi/2] (a material's epd_g1, where G1 depends on
    /// beta tan theta); finite at pi/2, where tan gives 1.6e16 in f64.
    BoundedLogTan { eps: f64, delta: f64 },
    /// e = asin(sqrt(x)), x in [0, 1]: xi of a sampling table. Near 0 the
    /// quantile of a density that starts linearly in theta^2 grows as sqrt(xi)
    /// ~ e, and near 1 the nodes crowd as 1 - xi ~ (pi/2 - e)^2, where heavy
    /// tails spread the last quantiles towards pi/2.
    AsinSqrt,
}

impl AxisEncoding {
    pub fn encode(&self, x: f64) -> f64 {
        match *self {
            AxisEncoding::Linear => x,
            AxisEncoding::Log => x.ln(),
            AxisEncoding::Reciprocal => 1.0 / x,
            AxisEncoding::ExpNegPower { k } => (-x.powf(-1.0 / k)).exp(),
            AxisEncoding::BoundedLog { eps, delta } => {
                if x == f64::INFINITY {
                    -delta.ln()
                } else {
                    ((x + eps) / (1.0 + delta * x)).ln()
                }
            }
            AxisEncoding::ShiftedReciprocal { shift } => 1.0 / (x + shift),
            AxisEncoding::ShiftedLog { shift } => (x - shift).ln(),
            AxisEncoding::LogGap { end, eps } => -(end + eps - x).ln(),
            AxisEncoding::LogPlusLogLog1pSq => x.ln() + (x * x).ln_1p().ln(),
            AxisEncoding::Log1pSq { scale } => (x / scale).powi(2).ln_1p(),
            AxisEncoding::BoundedLogTan { eps, delta } => AxisEncoding::BoundedLog { eps, delta }.encode(x.tan()),
            AxisEncoding::AsinSqrt => x.sqrt().asin(),
        }
    }

    pub fn decode(&self, e: f64) -> f64 {
        match *self {
            AxisEncoding::Linear => e,
            AxisEncoding::Log => e.exp(),
            AxisEncoding::Reciprocal => 1.0 / e,
            AxisEncoding::ExpNegPower { k } => (-e.ln()).powf(-k),
            AxisEncoding::BoundedLog { eps, delta } => {
                if e >= -delta.ln() {
                    f64::INFINITY
                } else {
                    // (x + eps) = z (1 + delta x)  =>  x = (z - eps) / (1 - delta z)
                    let z = e.exp();
                    ((z - eps) / (1.0 - delta * z)).max(0.0)
                }
            }
            AxisEncoding::ShiftedReciprocal { shift } => 1.0 / e - shift,
            AxisEncoding::ShiftedLog { shift } => shift + e.exp(),
            AxisEncoding::LogGap { end, eps } => end + eps - (-e).exp(),
            AxisEncoding::LogPlusLogLog1pSq => {
                // Monotone: bisection in ln x (to f64 resolution).
                let (mut lo, mut hi) = (-300.0f64, 300.0f64);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if self.encode(mid.exp()) < e {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                (0.5 * (lo + hi)).exp()
            }
            AxisEncoding::Log1pSq { scale } => scale * e.exp_m1().max(0.0).sqrt(),
            AxisEncoding::BoundedLogTan { eps, delta } => AxisEncoding::BoundedLog { eps, delta }.decode(e).atan(),
            AxisEncoding::AsinSqrt => e.sin().powi(2).min(1.0),
        }
    }

    /// The formula as text, for manifests and other runtimes.
    pub fn formula(&self) -> String {
        match *self {
            AxisEncoding::Linear => "e = x".into(),
            AxisEncoding::Log => "e = ln(x)".into(),
            AxisEncoding::Reciprocal => "e = 1/x".into(),
            AxisEncoding::ExpNegPower { k } => format!("e = exp(-x^(-1/{k})); e(0) = 0, e(+inf) = 1"),
            AxisEncoding::BoundedLog { eps, delta } => {
                format!("e = ln((x + {eps:e}) / (1 + {delta:e} x)); e(+inf) = -ln({delta:e})")
            }
            AxisEncoding::ShiftedReciprocal { shift } => format!("e = 1/(x + {shift})"),
            AxisEncoding::ShiftedLog { shift } if shift < 0.0 => format!("e = ln(x + {})", -shift),
            AxisEncoding::ShiftedLog { shift } => format!("e = ln(x - {shift})"),
            AxisEncoding::LogGap { end, eps } => format!("e = -ln({end} + {eps:e} - x)"),
            AxisEncoding::LogPlusLogLog1pSq => "e = ln(x) + ln(ln(1 + x^2))".into(),
            AxisEncoding::Log1pSq { scale } => format!("e = ln(1 + (x / {scale:?})^2)"),
            AxisEncoding::BoundedLogTan { eps, delta } => {
                format!("e = ln((tan(x) + {eps:e}) / (1 + {delta:e} tan(x)))")
            }
            AxisEncoding::AsinSqrt => "e = asin(sqrt(x))".into(),
        }
    }
}

/// A coordinate outside an axis, or not a number.
#[derive(Clone, Debug, PartialEq)]
pub struct DomainError {
    pub axis: String,
    pub value: f64,
    pub min: f64,
    pub max: f64,
}

impl fmt::Display for DomainError {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        if self.value.is_nan() {
            write!(f, "{} is NaN", self.axis)
        } else {
            write!(f, "{} = {} is outside the table's domain [{}, {}]", self.axis, self.value, self.min, self.max)
        }
    }
}

impl std::error::Error for DomainError {}

#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    pub nodes: Vec<f64>,
    pub encoding: AxisEncoding,
    /// e(nodes), strictly monotone.
    encoded: Vec<f64>,
    /// (e(first node), 1 / spacing) where the nodes are uniform in e (`is_uniform`): `locate` guesses the cell
    /// from them and corrects the guess, instead of a binary search (a fifth of a fit's time was the search).
    uniform: Option<(f64, f64)>,
}

impl Axis {
    /// An axis with the given nodes; panics unless e(nodes) is finite and
    /// strictly monotone (a programming error in a preset).
    pub fn new(name: &str, nodes: Vec<f64>, encoding: AxisEncoding) -> Axis {
        let encoded: Vec<f64> = nodes.iter().map(|&x| encoding.encode(x)).collect();
        assert!(nodes.len() >= 2, "axis {name}: needs at least two nodes");
        let increasing = encoded[1] > encoded[0];
        let monotone = encoded.windows(2).all(|w| if increasing { w[1] > w[0] } else { w[1] < w[0] });
        assert!(
            monotone && encoded.iter().all(|e| e.is_finite()),
            "axis {name}: encoded nodes must be finite and strictly monotone"
        );
        let n = encoded.len();
        let (e0, e1) = (encoded[0], encoded[n - 1]);
        let uniform = encoded
            .iter()
            .enumerate()
            .all(|(i, &e)| (e - (e0 + (e1 - e0) * i as f64 / (n - 1) as f64)).abs() <= 1e-9 * (e1 - e0).abs())
            .then_some((e0, (n - 1) as f64 / (e1 - e0)));
        Axis { name: name.to_string(), nodes, encoding, encoded, uniform }
    }

    /// `n` nodes uniformly spaced in the encoding from e(first) to e(last);
    /// the end nodes are `first` and `last` exactly.
    pub fn uniform(name: &str, encoding: AxisEncoding, first: f64, last: f64, n: usize) -> Axis {
        let (e0, e1) = (encoding.encode(first), encoding.encode(last));
        let nodes = (0..n)
            .map(|i| match i {
                0 => first,
                _ if i == n - 1 => last,
                _ => encoding.decode(e0 + (e1 - e0) * i as f64 / (n - 1) as f64),
            })
            .collect();
        Axis::new(name, nodes, encoding)
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    pub fn min(&self) -> f64 {
        self.nodes.iter().copied().fold(f64::INFINITY, f64::min)
    }

    pub fn max(&self) -> f64 {
        self.nodes.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether the nodes are equally spaced in the encoding (to 1e-9 of the span),
    /// so that a runtime can find the cell without a search.
    pub fn is_uniform(&self) -> bool {
        self.uniform.is_some()
    }

    /// Encoded node coordinates.
    pub fn encoded(&self) -> &[f64] {
        &self.encoded
    }

    /// The smallest run of nodes (indices, at least two) whose cells cover
    /// [lo, hi]; an error when [lo, hi] leaves the axis.
    pub fn covering(&self, lo: f64, hi: f64) -> Result<std::ops::RangeInclusive<usize>, DomainError> {
        let (i, _) = self.locate(lo)?;
        let (j, _) = self.locate(hi)?;
        let (a, b) = (i.min(j), i.max(j) + 1);
        Ok(a..=b.min(self.len() - 1))
    }

    /// The axis restricted to the nodes in `range`.
    pub fn slice(&self, range: std::ops::RangeInclusive<usize>) -> Axis {
        Axis::new(&self.name, self.nodes[range].to_vec(), self.encoding)
    }

    /// The cell containing x and the interpolation weight of its upper node.
    pub fn locate(&self, x: f64) -> Result<(usize, f64), DomainError> {
        let err = || DomainError { axis: self.name.clone(), value: x, min: self.min(), max: self.max() };
        let e = self.encoding.encode(x);
        let n = self.encoded.len();
        let sign = if self.encoded[n - 1] > self.encoded[0] { 1.0 } else { -1.0 };
        let (lo, hi) = (sign * self.encoded[0], sign * self.encoded[n - 1]);
        let se = sign * e;
        if x.is_nan() || e.is_nan() || se < lo || se > hi {
            return Err(err());
        }
        // First node strictly above e, clamped so that the cell [i, i+1] exists. On a uniform axis the
        // guess from the spacing is moved to it: the same node as the binary search's.
        let above = |k: usize| sign * self.encoded[k] > se;
        let upper = match self.uniform {
            Some((e0, inv)) => {
                // truncation is floor here (clamped at 0 first), without libm's floor call
                let mut k = ((e - e0) * inv + 1.0).clamp(0.0, n as f64) as usize;
                while k > 0 && above(k - 1) {
                    k -= 1;
                }
                while k < n && !above(k) {
                    k += 1;
                }
                k
            }
            None => self.encoded.partition_point(|&v| sign * v <= se),
        }
        .clamp(1, n - 1);
        let i = upper - 1;
        let t = (e - self.encoded[i]) / (self.encoded[i + 1] - self.encoded[i]);
        Ok((i, t.clamp(0.0, 1.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform axis' guessed cell is the binary search's, at nodes, between them and at the ends, increasing
    /// or decreasing in the encoding.
    #[test]
    fn uniform_axes_locate_as_the_binary_search() {
        let axes = [
            Axis::uniform("p", AxisEncoding::Reciprocal, 5.0, 0.05, 160),
            Axis::uniform("beta", AxisEncoding::Log, 0.005, 0.5, 67),
            Axis::uniform("x", AxisEncoding::Linear, -1.0, 3.0, 5),
        ];
        for axis in &axes {
            assert!(axis.uniform.is_some(), "{}", axis.name);
            let mut search = axis.clone();
            search.uniform = None;
            let (e0, e1) = (axis.encoded[0], axis.encoded[axis.encoded.len() - 1]);
            let mut points: Vec<f64> = axis.nodes.clone();
            points.extend((0..=4000).map(|k| axis.encoding.decode(e0 + (e1 - e0) * k as f64 / 4000.0)));
            points.extend(axis.nodes.windows(2).map(|w| 0.5 * (w[0] + w[1])));
            for x in points {
                assert_eq!(axis.locate(x), search.locate(x), "{} at {x}", axis.name);
            }
        }
        assert!(Axis::new("x", vec![0.0, 1.0, 3.0], AxisEncoding::Linear).uniform.is_none());
    }

    #[test]
    fn encodings_round_trip() {
        // (encoding, scale): x round-trips to within 1e-9 of max(|x|, scale),
        // the resolution an encoding with a shift or an end point has.
        let encs = [
            (AxisEncoding::Linear, 0.0),
            (AxisEncoding::Log, 0.0),
            (AxisEncoding::Reciprocal, 0.0),
            (AxisEncoding::ExpNegPower { k: 20.0 }, 0.0),
            (AxisEncoding::BoundedLog { eps: 1e-25, delta: 1e-8 }, 0.0),
            (AxisEncoding::ShiftedReciprocal { shift: 10.0 }, 10.0),
            (AxisEncoding::ShiftedLog { shift: -1.0 }, 1.0),
            (AxisEncoding::LogGap { end: 1e6, eps: 1e-4 }, 1e6),
            (AxisEncoding::LogPlusLogLog1pSq, 0.0),
            (AxisEncoding::Log1pSq { scale: 0.5 }, 0.0),
        ];
        for (enc, scale) in &encs {
            for &x in &[1e-20, 1e-3, 0.5, 1.0, 7.0, 1e5] {
                let back = enc.decode(enc.encode(x));
                assert!((back - x).abs() <= 1e-9 * x.abs().max(*scale), "{enc:?} x={x} back={back}");
            }
        }
        let bl = AxisEncoding::BoundedLog { eps: 1e-25, delta: 1e-8 };
        assert_eq!(bl.decode(bl.encode(f64::INFINITY)), f64::INFINITY);
        assert_eq!(bl.decode(bl.encode(0.0)), 0.0);
        let enp = AxisEncoding::ExpNegPower { k: 20.0 };
        assert_eq!(enp.encode(0.0), 0.0);
        assert_eq!(enp.encode(f64::INFINITY), 1.0);
    }

    #[test]
    fn locate_finds_cells_on_increasing_and_decreasing_axes() {
        let inc = Axis::new("x", vec![0.0, 1.0, 3.0], AxisEncoding::Linear);
        assert_eq!(inc.locate(0.0).unwrap(), (0, 0.0));
        assert_eq!(inc.locate(2.0).unwrap(), (1, 0.5));
        assert_eq!(inc.locate(3.0).unwrap(), (1, 1.0));
        assert!(inc.locate(3.5).is_err());
        assert!(inc.locate(f64::NAN).is_err());
        // p = 5/(i+1), reciprocal encoding: e = (i+1)/5.
        let dec = Axis::new("p", (0..4).map(|i| 5.0 / (i as f64 + 1.0)).collect(), AxisEncoding::Reciprocal);
        let (i, t) = dec.locate(2.0).unwrap(); // e = 0.5, between e=0.4 (i=1) and 0.6
        assert_eq!(i, 1);
        assert!((t - 0.5).abs() < 1e-12);
        assert!(dec.locate(6.0).is_err());
        assert!(dec.is_uniform());
    }

    #[test]
    fn uniform_axis_keeps_exact_ends() {
        let a = Axis::uniform("a", AxisEncoding::BoundedLog { eps: 1e-25, delta: 1e-8 }, 0.0, f64::INFINITY, 50);
        assert_eq!(a.nodes[0], 0.0);
        assert_eq!(a.nodes[49], f64::INFINITY);
        assert!(a.is_uniform());
        assert_eq!(a.locate(f64::INFINITY).unwrap(), (48, 1.0));
        assert_eq!(a.locate(0.0).unwrap(), (0, 0.0));
    }
}
