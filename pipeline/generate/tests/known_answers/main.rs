//! Known-answer tests of the builders: closed forms, independent quadratures (the `quadrature`
//! crate's double-exponential rule, not this crate's Gauss-Kronrod) and properties (proptest) of
//! docs/maths.md's functions, module by module: `epd` (N(p), Lambda, G1), `kcorr` (R), `zh`
//! (S, D, the zonal-harmonic convolution), `properties` (monotonicity and limits at the domain
//! edges). `cargo test -p twoscale-generate` runs them.

mod epd;
mod kcorr;
mod properties;
mod zh;

/// Double-exponential quadrature (the `quadrature` crate, independent of the
/// project's Gauss-Kronrod code) over [lo, hi], split into pieces that start
/// at width `first` and grow by `growth`, so that mass near `lo` on a long
/// interval is not missed (that crate stops at ~385 evaluations per call).
pub fn de_split(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, first: f64, growth: f64) -> f64 {
    let (mut a, mut step, mut sum) = (lo, first, 0.0);
    while a < hi {
        let b = (a + step).min(hi);
        sum += quadrature::double_exponential::integrate(f, a, b, 1e-15).integral;
        a = b;
        step *= growth;
    }
    sum
}
