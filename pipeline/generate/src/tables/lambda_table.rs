//! Smith's Lambda(p, a) of one p (docs/maths.md section 2) as a piecewise cubic in t = a^2, read
//! without a logarithm: the cell is t's f64 exponent and top CELL_BITS mantissa bits, the weight
//! the rest of the mantissa. The albedo rule needs Lambda at a = beta tan theta_o for every
//! direction, where the geometry gives tan^2 theta_o = (1 - o_z^2)/o_z^2 without a root or a log;
//! a table uniform in ln a (the old `LambdaCurve`) costs a ln per direction, which was a fifth of
//! the rule's time (docs/benchmarks.md).
//!
//! Within one octave of t the cells are uniform in t, so each cell's cubic is a polynomial in its
//! weight f in [0, 1); its coefficients come from 4-point Lagrange interpolation in t through the
//! nodes around the cell (spaced unevenly where the stencil crosses an octave's end).

use super::epd_math::{lambda, m1};
use rayon::prelude::*;

/// Cells per octave of t: 2^CELL_BITS, a relative step in a of at most 2^-(CELL_BITS + 1).
const CELL_BITS: u32 = 5;
const SHIFT: u32 = 52 - CELL_BITS;
const MANTISSA: u64 = (1 << SHIFT) - 1;
const ONE: u64 = 0x3ff0_0000_0000_0000;
/// t up to 2^T_HI (a = 2^22 ~ e^15.2), beyond which Lambda = a M1(p) - 1/2 to f64 precision, and
/// down to where Lambda falls below FLOOR (1 + Lambda_i + Lambda_o does not see it), at most to
/// 2^T_LO (a = 2^-72 ~ e^-50, where Lambda < 1e-60 for every p >= 0.05); 0 below.
const T_LO: i32 = -144;
const T_HI: i32 = 44;
/// The first cell's index in t's bits shifted by SHIFT, and the number of cells.
const BASE: u64 = ((1023 + T_LO) as u64) << CELL_BITS;
const CELLS: usize = ((T_HI - T_LO) as usize) << CELL_BITS;
const FLOOR: f64 = 1e-17;

pub struct LambdaTable {
    pub p: f64,
    m1: f64,
    /// The first cell's index in t's bits shifted by SHIFT, and t there.
    base: u64,
    t_first: f64,
    /// c0 + f (c1 + f (c2 + f c3)) per cell, from `base` on.
    cells: Vec<[f64; 4]>,
}

/// t at node k (the lower end of cell k).
fn node(k: usize) -> f64 {
    f64::from_bits((BASE + k as u64) << SHIFT)
}

impl LambdaTable {
    /// Lambda at the nodes by `epd_math::lambda` (none below the cell that holds FLOOR), then each
    /// cell's cubic.
    pub fn new(p: f64) -> LambdaTable {
        let value = |k: usize| lambda(p, node(k).sqrt());
        // Lambda grows with a: the first node at FLOOR or above, by bisection, and the cells from
        // two nodes below it (their stencils reach one node down).
        let (mut lo, mut hi) = (0, CELLS);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if value(mid) >= FLOOR {
                hi = mid
            } else {
                lo = mid + 1
            }
        }
        let first = lo.saturating_sub(2).min(CELLS - 3);
        let t: Vec<f64> = (first..=CELLS).map(node).collect();
        let values: Vec<f64> = (first..=CELLS).into_par_iter().map(value).collect();
        let last = t.len() - 2;
        let cells = (0..=last)
            .map(|k| {
                let s = k.saturating_sub(1).min(last - 2);
                let width = t[k + 1] - t[k];
                let at: [f64; 4] = std::array::from_fn(|m| (t[s + m] - t[k]) / width);
                cubic_through(at, std::array::from_fn(|m| values[s + m]))
            })
            .collect();
        LambdaTable { p, m1: m1(p), base: BASE + first as u64, t_first: t[0], cells }
    }

    /// Lambda(p, sqrt(t)): 0 below the first cell (and for t <= 0), the asymptote from 2^T_HI.
    #[inline(always)]
    pub fn at_t(&self, t: f64) -> f64 {
        let bits = t.to_bits();
        let k = (bits >> SHIFT).wrapping_sub(self.base);
        match self.cells.get(k as usize) {
            Some(c) => {
                let f = f64::from_bits(((bits & MANTISSA) << CELL_BITS) | ONE) - 1.0;
                c[0] + f * (c[1] + f * (c[2] + f * c[3]))
            }
            // Below the first cell (or t <= 0, whose bits wrap below it) or past the last.
            None if t < self.t_first => 0.0,
            None => t.sqrt() * self.m1 - 0.5,
        }
    }
}

/// The monomial coefficients of the cubic through (x_m, y_m), m = 0..3 (Lagrange's form expanded).
fn cubic_through(x: [f64; 4], y: [f64; 4]) -> [f64; 4] {
    let mut c = [0.0; 4];
    for m in 0..4 {
        // prod over n != m of (f - x_n): coefficients of f^0..f^3.
        let mut poly = [1.0, 0.0, 0.0, 0.0];
        let mut denominator = 1.0;
        for n in (0..4).filter(|&n| n != m) {
            for d in (1..4).rev() {
                poly[d] = poly[d - 1] - x[n] * poly[d];
            }
            poly[0] *= -x[n];
            denominator *= x[m] - x[n];
        }
        for d in 0..4 {
            c[d] += y[m] * poly[d] / denominator;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::sampling::SplitMix64;

    #[test]
    fn cubic_through_reproduces_a_cubic_on_uneven_nodes() {
        let f = |x: f64| 0.5 - 1.5 * x + 0.25 * x * x + 2.0 * x * x * x;
        let x = [-0.5, 0.0, 1.0, 3.0];
        let c = cubic_through(x, x.map(f));
        for (got, want) in c.iter().zip([0.5, -1.5, 0.25, 2.0]) {
            assert!((got - want).abs() < 1e-14, "{c:?}");
        }
    }

    /// Against the quadrature at random a (log-uniform over the tabulated range and beyond both
    /// ends): within 2e-8 absolute where Lambda < 1, 2e-8 relative above (the cubic's error on the
    /// asymptote's sqrt t), for light and heavy tails and the near-disk p = 5 (whose Lambda turns on
    /// within a few per cent of a = 1).
    #[test]
    fn lambda_table_against_the_quadrature() {
        let mut rng = SplitMix64::new(7);
        for p in [0.05, 0.3, 1.0, 2.0, 5.0] {
            let table = LambdaTable::new(p);
            let mut worst: f64 = 0.0;
            for _ in 0..4000 {
                let a = (-60.0 + 80.0 * rng.uniform()).exp();
                let want = lambda(p, a);
                let err = (table.at_t(a * a) - want).abs() / want.max(1.0);
                worst = worst.max(err);
            }
            assert!(worst < 2e-8, "p = {p}: {worst:e}");
            assert_eq!(table.at_t(0.0), 0.0);
            assert_eq!(table.at_t(-1e-300), 0.0);
            assert_eq!(table.at_t(f64::INFINITY), f64::INFINITY);
        }
    }
}
