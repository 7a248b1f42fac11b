//! What the jobs of one build share, passed to them explicitly
//! (`BuildOptions::context`): zonal-harmonic coefficient rows, and
//! zh_convolution's fits on the default domain.
//!
//! zh_convolution and zh_lobe, built by one stage, need the coefficient rows
//! of the nodes they share; computed once per build, as is the standard rule's weighted Legendre
//! matrix they are computed with (nodes x degree: every material's tables ask for it several times).
//! A row does not depend on the other rows it was computed with (`zh_grid::s_coefficients`,
//! `d_coefficients`), so a shared row is the row a fresh computation gives. A job without a context (a
//! benchmark's) starts from cold.

use super::zh_grid::{d_coefficients, s_coefficients, Fits};
use super::zh_math::ThetaRule;
use ndarray::Array2;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

/// Which lobe a coefficient row belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Lobe {
    S,
    D,
}

/// Rows by (lobe, degree, bits of the node's two parameters), at the standard rule of the degree.
type RowCache = BTreeMap<(Lobe, usize, u64, u64), Vec<f64>>;

#[derive(Default)]
pub struct BuildContext {
    rows: Mutex<RowCache>,
    /// The standard rule of a degree and its weighted Legendre matrix.
    rules: Mutex<BTreeMap<usize, Arc<(ThetaRule, Array2<f64>)>>>,
    fits: Mutex<Option<Fits>>,
    /// epd_albedo's E over the theta_i nodes, by bits of (p, beta) and the node count.
    albedo: Mutex<BTreeMap<(u64, u64, usize), Arc<Vec<f64>>>>,
}

impl std::fmt::Debug for BuildContext {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let rows = self.rows.lock().expect("not poisoned").len();
        write!(f, "BuildContext {{ rows: {rows}, fits: {} }}", self.fits.lock().expect("not poisoned").is_some())
    }
}

impl BuildContext {
    /// `zh_grid::s_coefficients` at the standard rule of `degree`, one row per (u, c).
    pub fn s_coefficients(&self, degree: usize, uc: &[(f64, f64)]) -> Array2<f64> {
        self.rows(Lobe::S, degree, uc, s_coefficients)
    }

    /// `zh_grid::d_coefficients` at the standard rule of `degree`, one row per (p, beta).
    pub fn d_coefficients(&self, degree: usize, pb: &[(f64, f64)]) -> Array2<f64> {
        self.rows(Lobe::D, degree, pb, d_coefficients)
    }

    /// zh_convolution's fits on the default domain, if this build made them.
    pub fn fits(&self) -> Option<Fits> {
        self.fits.lock().expect("not poisoned").clone()
    }

    pub fn remember_fits(&self, fits: Fits) {
        *self.fits.lock().expect("not poisoned") = Some(fits);
    }

    /// E at the theta_i nodes (`n_theta` of them) for p and each of `betas`, computing the missing
    /// columns with `compute` (epd_albedo and epd_albedo_avg of one build share them).
    pub fn albedo_columns(
        &self,
        p: f64,
        betas: &[f64],
        n_theta: usize,
        compute: impl Fn(&[f64]) -> Vec<Vec<f64>>,
    ) -> Vec<Arc<Vec<f64>>> {
        let key = |beta: f64| (p.to_bits(), beta.to_bits(), n_theta);
        let missing: Vec<f64> = {
            let cache = self.albedo.lock().expect("not poisoned");
            betas.iter().copied().filter(|&b| !cache.contains_key(&key(b))).collect()
        };
        if !missing.is_empty() {
            let columns = compute(&missing);
            let mut cache = self.albedo.lock().expect("not poisoned");
            for (&b, column) in missing.iter().zip(columns) {
                cache.insert(key(b), Arc::new(column));
            }
        }
        let cache = self.albedo.lock().expect("not poisoned");
        betas.iter().map(|&b| cache[&key(b)].clone()).collect()
    }

    /// The standard rule of `degree` and its weighted Legendre matrix, made on first use.
    fn rule(&self, degree: usize) -> Arc<(ThetaRule, Array2<f64>)> {
        let mut rules = self.rules.lock().expect("not poisoned");
        let made = rules.entry(degree).or_insert_with(|| {
            let rule = ThetaRule::standard(degree);
            let legendre = rule.weighted_legendre(degree);
            Arc::new((rule, legendre))
        });
        Arc::clone(made)
    }

    /// The rows of `nodes`, computing (and keeping) the missing ones with `compute`.
    fn rows(
        &self,
        lobe: Lobe,
        degree: usize,
        nodes: &[(f64, f64)],
        compute: fn(&ThetaRule, &Array2<f64>, &[(f64, f64)]) -> Array2<f64>,
    ) -> Array2<f64> {
        let key = |&(a, b): &(f64, f64)| (lobe, degree, a.to_bits(), b.to_bits());
        let mut missing: Vec<(f64, f64)> = {
            let cache = self.rows.lock().expect("not poisoned");
            nodes.iter().filter(|n| !cache.contains_key(&key(n))).copied().collect()
        };
        missing.sort_by_key(key);
        missing.dedup_by_key(|n| key(n));
        tracing::debug!(
            "coefficient rows at degree {degree}: {} of {} computed, the rest shared",
            missing.len(),
            nodes.len()
        );
        if !missing.is_empty() {
            let rule = self.rule(degree);
            let rows = compute(&rule.0, &rule.1, &missing);
            let mut cache = self.rows.lock().expect("not poisoned");
            for (n, row) in missing.iter().zip(rows.rows()) {
                cache.insert(key(n), row.to_vec());
            }
        }
        let cache = self.rows.lock().expect("not poisoned");
        let mut out = Array2::zeros((nodes.len(), degree));
        for (i, n) in nodes.iter().enumerate() {
            out.row_mut(i).assign(&ndarray::ArrayView1::from(cache[&key(n)].as_slice()));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_rows_are_the_rows_a_fresh_computation_gives() {
        // Two requests overlapping in part (the second reuses rows of the first,
        // computed in another batch), against each node computed on its own.
        let degree = 64;
        let first: Vec<(f64, f64)> = (0..40).map(|i| (0.1 + i as f64, 1.5 + 0.01 * i as f64)).collect();
        let second: Vec<(f64, f64)> = first[30..].iter().copied().chain([(77.0, 2.9), (0.0, 1.02)]).collect();
        let rule = ThetaRule::standard(degree);
        let w = rule.weighted_legendre(degree);
        let context = BuildContext::default();
        for nodes in [&first, &second] {
            let (s, d) = (context.s_coefficients(degree, nodes), context.d_coefficients(degree, nodes));
            for (i, &n) in nodes.iter().enumerate() {
                assert_eq!(s.row(i), s_coefficients(&rule, &w, &[n]).row(0), "F at {n:?}");
                assert_eq!(d.row(i), d_coefficients(&rule, &w, &[n]).row(0), "G at {n:?}");
            }
        }
        assert_eq!(context.rows.lock().unwrap().len(), 2 * (40 + 2));
    }
}
