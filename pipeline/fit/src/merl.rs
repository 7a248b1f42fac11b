//! MERL isotropic BRDF files (Matusik et al. 2003), read as the MERL reader defines them
//! (docs/fit.md "The file"):
//! - three int32 dimensions (90, 90, 180), little-endian;
//! - then 3 x 1,458,000 float64: the whole red block, then green, then blue, each value times its
//!   scale (1/1500, 1.15/1500, 1.66/1500) being rho;
//! - index phi_d + 180 (theta_d + 90 theta_h), theta_h's bin sqrt(theta_h / (pi/2)) 90;
//! - a negative value marks a sample below the horizon.
//!
//! Sample (i, j, k) stands at theta_h = (i/90)^2 pi/2, theta_d = j pi/180, phi_d = k pi/180 (which
//! inverts the index map at whole indices): h = (sin theta_h, 0, cos theta_h), wi the difference
//! vector (theta_d, phi_d) rotated by theta_h about y (MERL's `half_diff_coords_to_std_coords`),
//! wo = 2 (wi.h) h - wi.

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// (theta_h, theta_d, phi_d) bins.
pub const DIMS: [usize; 3] = [90, 90, 180];
/// Samples per channel.
pub const PER_CHANNEL: usize = DIMS[0] * DIMS[1] * DIMS[2];
/// rho = stored value x scale, per channel (red, green, blue).
pub const SCALES: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// The file's size in bytes: the header and three blocks of float64.
pub const FILE_BYTES: usize = 12 + 3 * PER_CHANNEL * 8;

/// The directions of a sample: unit vectors in the local frame (z the normal).
#[derive(Clone, Copy, Debug)]
pub struct Directions {
    pub wi: [f64; 3],
    pub wo: [f64; 3],
    pub theta_h: f64,
    pub cos_d: f64,
}

/// The directions of bin (i, j, k) (theta_h, theta_d, phi_d).
pub fn directions(i: usize, j: usize, k: usize) -> Directions {
    let x = i as f64 / DIMS[0] as f64;
    let theta_h = x * x * FRAC_PI_2;
    let (theta_d, phi_d) = (j as f64 * PI / 180.0, k as f64 * PI / 180.0);
    let (sh, ch) = theta_h.sin_cos();
    let (sd, cd) = theta_d.sin_cos();
    let (sp, cp) = phi_d.sin_cos();
    let d = [sd * cp, sd * sp, cd];
    let wi = [d[0] * ch + d[2] * sh, d[1], -d[0] * sh + d[2] * ch];
    let h = [sh, 0.0, ch];
    let ih = wi[0] * h[0] + wi[2] * h[2];
    let wo = [2.0 * ih * h[0] - wi[0], -wi[1], 2.0 * ih * h[2] - wi[2]];
    Directions { wi, wo, theta_h, cos_d: cd }
}

/// One measured sample above the horizon: its bins and rho per channel.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub bin: [u8; 3],
    pub rho: [f64; 3],
}

impl Sample {
    pub fn directions(&self) -> Directions {
        directions(self.bin[0] as usize, self.bin[1] as usize, self.bin[2] as usize)
    }

    /// The flat index of the bin in a channel block.
    pub fn index(&self) -> usize {
        let [i, j, k] = self.bin.map(usize::from);
        k + DIMS[2] * (j + DIMS[1] * i)
    }
}

/// A MERL file's valid samples (in index order) and how many were skipped.
#[derive(Clone, Debug)]
pub struct Measured {
    pub samples: Vec<Sample>,
    /// Marked below the horizon (negative) by the file.
    pub marked: usize,
    /// Not marked, but with wi or wo at or below the horizon (cos < 1e-6) at the bin's directions.
    pub grazing: usize,
}

/// The cosine below which a direction counts as below the horizon (the model's 1 / cos factors).
pub const MIN_COS: f64 = 1e-6;

/// What a bin of the file holds.
enum Bin {
    /// A NaN or an infinity: the value, the bin and the channel.
    Bad(f64, [usize; 3], usize),
    /// Marked below the horizon (negative).
    Marked,
    /// At a grazing direction.
    Grazing,
    Valid(Sample),
}

/// Reads and checks a MERL file: a wrong size or dimension, a NaN or an infinity, or no valid
/// sample is an error naming the file.
pub fn read(path: &Path) -> Result<Measured> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse(&bytes).with_context(|| format!("{}", path.display()))
}

/// `read` on the file's bytes.
pub fn parse(bytes: &[u8]) -> Result<Measured> {
    if bytes.len() < 12 {
        bail!("{} bytes: not a MERL file (a header of three int32 first)", bytes.len());
    }
    let dims: Vec<i32> = bytes[..12].chunks_exact(4).map(|b| i32::from_le_bytes(b.try_into().unwrap())).collect();
    if dims != [90, 90, 180] {
        bail!("dimensions {dims:?}: a MERL isotropic file has (90, 90, 180)");
    }
    if bytes.len() != FILE_BYTES {
        let how = if bytes.len() < FILE_BYTES { "truncated" } else { "too long" };
        bail!("{how}: {} bytes where the header announces {FILE_BYTES} (3 x 1,458,000 float64)", bytes.len());
    }
    let value = |c: usize, n: usize| {
        let at = 12 + 8 * (c * PER_CHANNEL + n);
        f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
    };
    // Each bin on its own (in parallel: the directions' trigonometry is most of the read), then in
    // index order, so that the first bad value reported is the file's first.
    let bins: Vec<Bin> = (0..PER_CHANNEL)
        .into_par_iter()
        .map(|n| {
            let raw = [value(0, n), value(1, n), value(2, n)];
            let (i, j, k) = (n / (DIMS[1] * DIMS[2]), n / DIMS[2] % DIMS[1], n % DIMS[2]);
            if let Some(c) = raw.iter().position(|v| !v.is_finite()) {
                return Bin::Bad(raw[c], [i, j, k], c);
            }
            if raw.iter().any(|&v| v < 0.0) {
                return Bin::Marked;
            }
            let d = directions(i, j, k);
            if d.wi[2] < MIN_COS || d.wo[2] < MIN_COS {
                return Bin::Grazing;
            }
            let rho = [raw[0] * SCALES[0], raw[1] * SCALES[1], raw[2] * SCALES[2]];
            Bin::Valid(Sample { bin: [i as u8, j as u8, k as u8], rho })
        })
        .collect();
    let (mut samples, mut marked, mut grazing) = (Vec::new(), 0, 0);
    for bin in bins {
        match bin {
            Bin::Bad(v, [i, j, k], c) => {
                bail!("{v} at bin (theta_h {i}, theta_d {j}, phi_d {k}) of channel {}", ["red", "green", "blue"][c])
            }
            Bin::Marked => marked += 1,
            Bin::Grazing => grazing += 1,
            Bin::Valid(s) => samples.push(s),
        }
    }
    if samples.is_empty() {
        bail!("no valid sample: every value is negative (below the horizon) or at a grazing direction");
    }
    Ok(Measured { samples, marked, grazing })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// MERL's own forward map (std_coords_to_half_diff_coords): the half vector's angle, the
    /// difference vector's angles in h's frame, and the continuous bin coordinates it puts them at
    /// (MERL's index truncates them).
    fn merl_bins(wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = dot(s, s).sqrt();
        let h = s.map(|x| x / n);
        let (theta_h, phi_h) = (h[2].acos(), h[1].atan2(h[0]));
        // rotate wi by -phi_h about z, then by -theta_h about y
        let (sp, cp) = (-phi_h).sin_cos();
        let t = [wi[0] * cp - wi[1] * sp, wi[0] * sp + wi[1] * cp, wi[2]];
        let (st, ct) = (-theta_h).sin_cos();
        let d = [t[0] * ct + t[2] * st, t[1], -t[0] * st + t[2] * ct];
        let (theta_d, mut phi_d) = (d[2].clamp(-1.0, 1.0).acos(), d[1].atan2(d[0]));
        if phi_d < 0.0 {
            phi_d += PI; // the isotropic BRDF's reciprocity folds phi_d into [0, pi)
        }
        [(theta_h / FRAC_PI_2).sqrt() * 90.0, theta_d / FRAC_PI_2 * 90.0, (phi_d / PI * 180.0) % 180.0]
    }

    #[test]
    fn a_bins_directions_map_back_to_the_bin() {
        for (i, j, k) in [(0, 0, 0), (1, 2, 3), (45, 30, 90), (89, 89, 179), (10, 60, 120), (70, 5, 45)] {
            let d = directions(i, j, k);
            assert!((dot(d.wi, d.wi) - 1.0).abs() < 1e-14 && (dot(d.wo, d.wo) - 1.0).abs() < 1e-14);
            let h = [d.theta_h.sin(), 0.0, d.theta_h.cos()];
            assert!((dot(d.wi, h) - d.cos_d).abs() < 1e-14, "wi.h = cos theta_d at {i} {j} {k}");
            // The forward map lands on the bin itself, not merely within it (phi_d is undefined
            // where theta_h or theta_d is 0).
            let got = merl_bins(d.wi, d.wo);
            let axes = if i > 0 && j > 0 { 3 } else { 2 };
            for (a, want) in [i, j, k].iter().enumerate().take(axes) {
                assert!((got[a] - *want as f64).abs() < 1e-6, "bin ({i}, {j}, {k}): {got:?}");
            }
        }
    }

    fn file(fill: impl Fn(usize, usize) -> f64) -> Vec<u8> {
        let mut b = Vec::with_capacity(FILE_BYTES);
        for d in [90i32, 90, 180] {
            b.extend(d.to_le_bytes());
        }
        for c in 0..3 {
            for n in 0..PER_CHANNEL {
                b.extend(fill(c, n).to_le_bytes());
            }
        }
        b
    }

    #[test]
    fn values_are_scaled_per_channel_and_negative_ones_skipped() {
        let bytes = file(|c, n| if n % 2 == 1 { -1.0 } else { (c + 1) as f64 * 1500.0 });
        let m = parse(&bytes).unwrap();
        assert_eq!(m.marked, PER_CHANNEL / 2);
        assert_eq!(m.samples.len() + m.marked + m.grazing, PER_CHANNEL);
        let s = m.samples[0];
        assert_eq!((s.bin, s.index()), ([0, 0, 0], 0));
        assert_eq!(s.rho, [1.0, 2.0 * 1.15, 3.0 * 1.66]);
        assert!(m.samples.iter().all(|s| s.index() % 2 == 0));
    }

    #[test]
    fn bad_files_are_refused() {
        let good = file(|_, _| 1.0);
        let err = |b: &[u8]| parse(b).unwrap_err().to_string();
        assert!(err(&good[..good.len() - 8]).starts_with("truncated"));
        assert!(err(&good[..7]).contains("not a MERL file"));
        let mut long = good.clone();
        long.push(0);
        assert!(err(&long).starts_with("too long"));
        let mut dims = good.clone();
        dims[8..12].copy_from_slice(&90i32.to_le_bytes());
        assert!(err(&dims).contains("dimensions [90, 90, 90]"));
        let mut nan = good.clone();
        let at = 12 + 8 * (PER_CHANNEL + 180 * 90 + 181);
        nan[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(err(&nan), "NaN at bin (theta_h 1, theta_d 1, phi_d 1) of channel green");
        assert!(err(&file(|_, _| -1.0)).starts_with("no valid sample"));
    }
}
