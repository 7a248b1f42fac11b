//! ln, exp and cos written without branches or library calls, so that a loop
//! mapping them over a slice compiles to SIMD code (the zh fits evaluate
//! q^-a = exp(-a ln q) at 1000 samples per step: with libm's scalar calls
//! those passes were 92 % of the paper build's profile). Both are within 1 ulp of libm
//! in their domain (tested beside their re-export in twoscale-generate's numerics); the
//! selects at the ends keep them total. The constants are fdlibm's, digit for digit.
//! In the reader crate because the batched BRDF (`brdf::MaterialBrdf::wave_parts`) uses them.
#![allow(clippy::excessive_precision)]

/// ln(2) split so that k * LN2_HI is exact for |k| < 2^20 (fdlibm).
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;

/// 2^52 + 2^51: adding it to |x| < 2^51 rounds x to an integer kept in the low mantissa bits.
const ROUND: f64 = 6_755_399_441_055_744.0;

/// ln(x) for normal positive x (x = +inf gives +inf, NaN gives NaN), by
/// fdlibm's method: x = 2^k m with m in [sqrt(2)/2, sqrt(2)), f = m - 1,
/// s = f / (2 + f), ln(1 + f) = f - f^2/2 + s (f^2/2 + R(s^2)), R minimax (error < 2^-58.45).
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    const LG: [f64; 7] = [
        6.666_666_666_666_735_130e-1,
        3.999_999_999_940_941_908e-1,
        2.857_142_874_366_239_149e-1,
        2.222_219_843_214_978_396e-1,
        1.818_357_216_161_805_012e-1,
        1.531_383_769_920_937_332e-1,
        1.479_819_860_511_658_591e-1,
    ];
    // Shift the exponent boundary from 1 to sqrt(2)/2 (0x3fe6a09e is its upper word).
    let hx = x.to_bits().wrapping_add((0x3ff0_0000 - 0x3fe6_a09e) << 32);
    // k = (hx >> 52) - 1023 as a float without an int-to-float conversion.
    const TWO52: f64 = 4_503_599_627_370_496.0;
    let k = f64::from_bits((hx >> 52) | TWO52.to_bits()) - (TWO52 + 1023.0);
    let m = f64::from_bits((hx & 0x000f_ffff_ffff_ffff).wrapping_add(0x3fe6_a09e << 32));
    let f = m - 1.0;
    let hfsq = 0.5 * f * f;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG[1] + w * (LG[3] + w * LG[5]));
    let t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])));
    let r = k * LN2_HI - ((hfsq - (s * (hfsq + t2 + t1) + k * LN2_LO)) - f);
    if x <= f64::MAX {
        r
    } else {
        x
    }
}

/// exp(x) for x <= 709 (exp(x) = 0 below -708, where it is below 3.3e-308;
/// NaN gives NaN): x = n ln 2 + r with |r| <= ln(2)/2, exp(r) by its Taylor
/// series to r^13 (truncation < 4e-18, summed by Estrin's scheme), scaled by 2^n through the exponent bits.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    const INV_FACT: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    let xc = x.clamp(-708.0, 709.0);
    let t = xc * std::f64::consts::LOG2_E + ROUND;
    let n = t - ROUND;
    let r = (xc - n * LN2_HI) - n * LN2_LO;
    // Estrin's scheme for the tail c2 + c3 r + ... + c13 r^11 (Horner's 13
    // serial steps left the SIMD units waiting on latency); 1 + r added last.
    let c = &INV_FACT;
    let (r2, pair) = (r * r, |i: usize| c[i] + c[i + 1] * r);
    let (r4, r8) = (r2 * r2, r2 * r2 * r2 * r2);
    let tail = ((pair(2) + r2 * pair(4)) + r4 * (pair(6) + r2 * pair(8))) + r8 * (pair(10) + r2 * pair(12));
    let p = 1.0 + (r + r2 * tail);
    // The low bits of t hold n; n + 1023 in [1, 2046] is the biased exponent of 2^n.
    let scale = f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
    if x < -708.0 {
        0.0
    } else {
        p * scale
    }
}

/// cos(x) for x in [0, pi] (the albedo rule's phi nodes): cos x = -sin y, y = x - pi/2 in
/// [-pi/2, pi/2], by sin's Taylor series to y^21 (truncation < 1.2e-18), Horner in y^2.
/// Within 4e-16 of libm there (2 ulp of 1; tested in twoscale-generate); not range-reduced beyond.
#[inline(always)]
pub fn cos_0_pi(x: f64) -> f64 {
    // (-1)^k / (2k + 1)!, k = 0..10
    const C: [f64; 11] = [
        1.0,
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
        -1.0 / 121_645_100_408_832_000.0,
        1.0 / 51_090_942_171_709_440_000.0,
    ];
    let y = x - std::f64::consts::FRAC_PI_2;
    let y2 = y * y;
    let mut s = C[10];
    for c in C[..10].iter().rev() {
        s = c + y2 * s;
    }
    -(y * s)
}
