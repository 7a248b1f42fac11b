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

use crate::sample::Sample;
use anyhow::{bail, Result};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

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

/// The cosine below which a direction counts as below the horizon (the model's 1 / cos factors).
pub const MIN_COS: f64 = 1e-6;

/// A MERL file's values, rho per channel and bin (NaN where the file marks the bin below the horizon),
/// to evaluate it between its bins (`rho`).
pub struct Merl {
    rho: Vec<[f64; 3]>,
}

/// What a bin of the file holds.
enum Bin {
    /// A NaN or an infinity: the value, the bin and the channel.
    Bad(f64, [usize; 3], usize),
    /// Marked below the horizon (negative).
    Marked,
    /// At a grazing direction.
    Grazing([f64; 3]),
    Valid(Sample),
}

/// The relative solid-angle measure dwi dwo of bin (i, j, k): dwi dwo = 4 cos theta_d sin theta_d
/// sin theta_h dtheta_h dtheta_d dphi_d dphi_h (Rusinkiewicz 1998) over the bin, theta_h's bin i
/// spanning [(i/90)^2, ((i+1)/90)^2] pi/2 and theta_d's [j, j + 1] pi/180 (both cut at pi/2); phi's
/// are constant.
fn bin_measure(i: usize, j: usize) -> f64 {
    let h = |i: usize| ((i as f64 / DIMS[0] as f64).powi(2) * FRAC_PI_2).min(FRAC_PI_2);
    let d = |j: usize| (j as f64 * PI / 180.0).min(FRAC_PI_2);
    (h(i).cos() - h(i + 1).cos()) * (d(j + 1).sin().powi(2) - d(j).sin().powi(2))
}

/// What a MERL file's samples left out, and why.
pub type Skipped = Vec<(&'static str, usize)>;

/// Reads and checks a MERL file's bytes: the file, its valid samples (their lobe nodes `lobe_nodes`'),
/// and those left out. A wrong size or dimension, a NaN or an infinity, or no valid sample is an error.
pub fn parse(bytes: &[u8]) -> Result<(Merl, Vec<Sample>, Skipped)> {
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
            let rho = [raw[0] * SCALES[0], raw[1] * SCALES[1], raw[2] * SCALES[2]];
            let d = directions(i, j, k);
            if d.wi[2] < MIN_COS || d.wo[2] < MIN_COS {
                return Bin::Grazing(rho);
            }
            let (node, measure) = ((i * DIMS[1] + j) as u32, bin_measure(i, j));
            Bin::Valid(Sample { wi: d.wi, wo: d.wo, rho, node, key: n as u64, measure })
        })
        .collect();
    let (mut samples, mut marked, mut grazing) = (Vec::new(), 0, 0);
    let mut grid = vec![[f64::NAN; 3]; PER_CHANNEL];
    for (n, bin) in bins.into_iter().enumerate() {
        match bin {
            Bin::Bad(v, [i, j, k], c) => {
                bail!("{v} at bin (theta_h {i}, theta_d {j}, phi_d {k}) of channel {}", ["red", "green", "blue"][c])
            }
            Bin::Marked => marked += 1,
            Bin::Grazing(rho) => {
                grid[n] = rho;
                grazing += 1
            }
            Bin::Valid(s) => {
                grid[n] = s.rho;
                samples.push(s)
            }
        }
    }
    if samples.is_empty() {
        bail!("no valid sample: every value is negative (below the horizon) or at a grazing direction");
    }
    Ok((Merl { rho: grid }, samples, vec![("marked below the horizon", marked), ("grazing", grazing)]))
}

/// The lobe nodes of the (theta_h, theta_d) bin pairs, i * 90 + j: (theta_h, cos theta_d).
pub fn lobe_nodes() -> Vec<(f64, f64)> {
    (0..DIMS[0] * DIMS[1])
        .map(|pair| {
            let d = directions(pair / DIMS[1], pair % DIMS[1], 0);
            (d.theta_h, d.cos_d)
        })
        .collect()
}

/// MERL's bin coordinates of (wi, wo): theta_h's sqrt(theta_h / (pi/2)) 90, theta_d's theta_d / (pi/2)
/// 90 and phi_d's phi_d / pi 180, phi_d folded into [0, pi) (rho(phi_d) = rho(phi_d + pi)). The
/// difference vector is wi rotated by -phi_h about z, then by -theta_h about y (MERL's
/// std_coords_to_half_diff_coords).
pub fn bin_coordinates(wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
    let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let norm = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    let h = s.map(|x| x / norm);
    let (theta_h, phi_h) = (h[2].clamp(-1.0, 1.0).acos(), h[1].atan2(h[0]));
    let (sp, cp) = phi_h.sin_cos();
    let (x, y) = (cp * wi[0] + sp * wi[1], cp * wi[1] - sp * wi[0]);
    let (st, ct) = theta_h.sin_cos();
    let (dx, dz) = (ct * x - st * wi[2], st * x + ct * wi[2]);
    let theta_d = dz.clamp(-1.0, 1.0).acos();
    let phi_d = y.atan2(dx).rem_euclid(PI);
    [(theta_h / FRAC_PI_2).sqrt() * 90.0, theta_d / FRAC_PI_2 * 90.0, phi_d / PI * 180.0]
}

impl Merl {
    /// rho per channel at (wi, wo), trilinear in the bin coordinates (`bin_coordinates`; theta_h and
    /// theta_d clamped to the last bin, phi_d periodic): the corners the file marks below the horizon
    /// take no part (the others' weights renormalised), and a point with none valid is 0; 0 where wi or
    /// wo is below the horizon.
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        if wi[2] < MIN_COS || wo[2] < MIN_COS {
            return [0.0; 3];
        }
        let u = bin_coordinates(wi, wo);
        // (index, weight) of the two corners along each axis
        let corners = |a: usize| -> [(usize, f64); 2] {
            let size = DIMS[a];
            let lo = u[a].floor();
            let frac = u[a] - lo;
            let lo = lo as usize;
            if a == 2 {
                [(lo % size, 1.0 - frac), ((lo + 1) % size, frac)]
            } else if lo >= size - 1 {
                [(size - 1, 1.0), (size - 1, 0.0)]
            } else {
                [(lo, 1.0 - frac), (lo + 1, frac)]
            }
        };
        let (ci, cj, ck) = (corners(0), corners(1), corners(2));
        let (mut total, mut weight) = ([0.0; 3], 0.0);
        for (i, wi_) in ci {
            for (j, wj) in cj {
                for (k, wk) in ck {
                    let v = self.rho[k + DIMS[2] * (j + DIMS[1] * i)];
                    let w = wi_ * wj * wk;
                    if v[0].is_nan() || w == 0.0 {
                        continue;
                    }
                    for ch in 0..3 {
                        total[ch] += w * v[ch];
                    }
                    weight += w;
                }
            }
        }
        if weight > 0.0 {
            total.map(|t| t / weight)
        } else {
            [0.0; 3]
        }
    }
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
        let (_, samples, skipped) = parse(&bytes).unwrap();
        let nodes = lobe_nodes();
        let marked = skipped.iter().find(|s| s.0.starts_with("marked")).unwrap().1;
        let grazing = skipped.iter().find(|s| s.0 == "grazing").unwrap().1;
        assert_eq!(marked, PER_CHANNEL / 2);
        assert_eq!(samples.len() + marked + grazing, PER_CHANNEL);
        let s = samples[0];
        assert_eq!((s.key, s.node), (0, 0));
        assert_eq!(s.rho, [1.0, 2.0 * 1.15, 3.0 * 1.66]);
        assert!(samples.iter().all(|s| s.key % 2 == 0));
        // A sample's node is its (theta_h, theta_d) bin pair, whose node holds its theta_h and cos theta_d.
        for s in samples.iter().step_by(9973) {
            let (i, j) = (s.key as usize / (DIMS[1] * DIMS[2]), s.key as usize / DIMS[2] % DIMS[1]);
            assert_eq!(s.node as usize, i * DIMS[1] + j);
            let (theta_h, cos_d) = nodes[s.node as usize];
            assert!((dot(s.wi, [theta_h.sin(), 0.0, theta_h.cos()]) - cos_d).abs() < 1e-14);
        }
    }

    /// The lookup returns the stored value at a bin's own directions, interpolates linearly between
    /// bins along each axis, leaves out the marked corners, and is 0 below the horizon.
    #[test]
    fn the_lookup_interpolates_between_bins_and_skips_marked_ones() {
        // rho = 1 + the bin's theta_d index, bins with odd theta_h index marked at theta_d 40
        let bytes = file(|c, n| {
            let (i, j) = (n / (DIMS[1] * DIMS[2]), n / DIMS[2] % DIMS[1]);
            if i % 2 == 1 && j == 40 {
                -1.0
            } else {
                (1.0 + j as f64) / SCALES[c]
            }
        });
        let (grid, _, _) = parse(&bytes).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * b.abs();
        for (i, j, k) in [(10, 20, 30), (30, 5, 170), (44, 60, 90)] {
            let d = directions(i, j, k);
            assert!(grid.rho(d.wi, d.wo).iter().all(|&v| close(v, 1.0 + j as f64)), "bin ({i}, {j}, {k})");
            // halfway in theta_d (at fixed theta_h and phi_d), rho is halfway
            let half = directions_at(i as f64, j as f64 + 0.5, k as f64);
            assert!(grid.rho(half.0, half.1).iter().all(|&v| close(v, 1.5 + j as f64)), "bin ({i}, {j}.5, {k})");
        }
        // Between theta_h bins 20 and 21 at theta_d 40: the marked corner (21) takes no part.
        let (wi, wo) = directions_at(20.5, 40.0, 10.0);
        assert!(grid.rho(wi, wo).iter().all(|&v| close(v, 41.0)));
        assert_eq!(grid.rho([0.0, 0.6, -0.8], [0.0, 0.0, 1.0]), [0.0; 3]);
    }

    /// The directions at fractional bin coordinates (i, j, k), as `directions` places whole ones.
    fn directions_at(i: f64, j: f64, k: f64) -> ([f64; 3], [f64; 3]) {
        let x = i / DIMS[0] as f64;
        let theta_h = x * x * FRAC_PI_2;
        let (theta_d, phi_d) = (j * PI / 180.0, k * PI / 180.0);
        let (sh, ch) = theta_h.sin_cos();
        let (sd, cd) = theta_d.sin_cos();
        let (sp, cp) = phi_d.sin_cos();
        let d = [sd * cp, sd * sp, cd];
        let wi = [d[0] * ch + d[2] * sh, d[1], -d[0] * sh + d[2] * ch];
        let ih = wi[0] * sh + wi[2] * ch;
        let wo = [2.0 * ih * sh - wi[0], -wi[1], 2.0 * ih * ch - wi[2]];
        (wi, wo)
    }

    #[test]
    fn bad_files_are_refused() {
        let good = file(|_, _| 1.0);
        let err = |b: &[u8]| parse(b).err().expect("refused").to_string();
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
