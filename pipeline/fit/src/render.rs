//! A fit judged as a viewer sees it: a sphere rendered under fixed lights with the measured file's own
//! interpolation and with a fitted model, compared pixel by pixel (SMAPE, as the talk compares models).
//!
//! The scene (docs/fit.md "The render"; examples/fit/compare.py renders the same one through the
//! runtimes, an independent path): a unit sphere seen orthographically along -z (the camera on +z: wo =
//! +z), `RESOLUTION` x `RESOLUTION` pixels, one sample at each pixel's centre, radiance = sum over the
//! lights of E rho(wi, wo) cos_i in the shading frame of the sphere's normal (Duff et al. 2017's frame;
//! the BRDFs are isotropic, so any tangent does). The lights, in the camera's frame (x right, y up):
//! - a key light from the upper left, E = 4, towards (-0.45, 0.55, 0.70): its highlight at theta_d 23 deg;
//! - a rim light from behind on the right, E = (3.0, 2.7, 2.2), towards (0.5, 0.17, -0.85): grazing
//!   reflection near the right edge, theta_d 74 deg;
//! - a sky of `SKY` directions of a Fibonacci lattice over the upper hemisphere (y > 0; equal solid
//!   angles 2 pi / SKY), E = (0.6, 0.75, 1.0) (0.3 + 0.7 y) 2 pi / SKY: blurred reflections and fill.
//!
//! A light within cos 1e-6 of a pixel's horizon adds nothing (MERL's own cut).

use crate::measured::File;
use crate::merl::MIN_COS;
use crate::model::{lobe_node, Geometry};
use crate::problem::Data;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// The image's width and height in pixels.
pub const RESOLUTION: usize = 64;
/// The sky's directions.
pub const SKY: usize = 120;
/// Lobe nodes per light (`Sphere::data`).
const NODES: usize = 1024;

/// One line for the JSON and the docs: what `smape` is measured on.
pub const SCENE: &str = "a unit sphere seen orthographically, 64 x 64 pixels, lit by a key light (E 4, towards \
    (-0.45, 0.55, 0.70)), a rim light from behind (E (3.0, 2.7, 2.2), towards (0.5, 0.17, -0.85)) and a sky of 120 \
    directions (a Fibonacci lattice over y > 0, E (0.6, 0.75, 1.0) (0.3 + 0.7 y) 2 pi / 120); SMAPE = mean over \
    the sphere's pixels and channels of |f - t| / ((|f| + |t|) / 2), those where both are 0 left out";

/// The lights: directions towards them (unit, camera frame) and their irradiance E per channel.
pub fn lights() -> Vec<([f64; 3], [f64; 3])> {
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    let mut out = vec![(unit([-0.45, 0.55, 0.70]), [4.0; 3]), (unit([0.5, 0.17, -0.85]), [3.0, 2.7, 2.2])];
    let golden = PI * (3.0 - 5f64.sqrt());
    for n in 0..SKY {
        let y = 1.0 - (n as f64 + 0.5) / SKY as f64;
        let (r, phi) = ((1.0 - y * y).sqrt(), n as f64 * golden);
        let e = (0.3 + 0.7 * y) * 2.0 * PI / SKY as f64;
        out.push(([r * phi.cos(), y, r * phi.sin()], [0.6 * e, 0.75 * e, e]));
    }
    out
}

/// The sphere's pixels and every (pixel, light) pair a light reaches, in the pixel's shading frame.
pub struct Sphere {
    /// The pixels on the sphere.
    pub pixels: usize,
    /// Per pair: its pixel, its light's irradiance, wi (towards the light) and wo (towards the camera).
    pixel: Vec<u32>,
    light: Vec<u16>,
    irradiance: Vec<[f64; 3]>,
    pub wi: Vec<[f64; 3]>,
    pub wo: Vec<[f64; 3]>,
}

impl Sphere {
    pub fn new(resolution: usize) -> Sphere {
        let lights = lights();
        let (mut pixel, mut light, mut irradiance) = (Vec::new(), Vec::new(), Vec::new());
        let (mut wi, mut wo) = (Vec::new(), Vec::new());
        let mut pixels = 0u32;
        for row in 0..resolution {
            for col in 0..resolution {
                let x = 2.0 * (col as f64 + 0.5) / resolution as f64 - 1.0;
                let y = 1.0 - 2.0 * (row as f64 + 0.5) / resolution as f64;
                if x * x + y * y >= 1.0 {
                    continue;
                }
                let n = [x, y, (1.0 - x * x - y * y).sqrt()];
                // Duff et al. 2017's frame (t, b, n), valid for n_z > -1
                let a = -1.0 / (1.0 + n[2]);
                let bxy = n[0] * n[1] * a;
                let (t, b) = ([1.0 + n[0] * n[0] * a, bxy, -n[0]], [bxy, 1.0 + n[1] * n[1] * a, -n[1]]);
                let local = |v: [f64; 3]| [dot(t, v), dot(b, v), dot(n, v)];
                for (m, (dir, e)) in lights.iter().enumerate() {
                    let l = local(*dir);
                    if l[2] > MIN_COS {
                        pixel.push(pixels);
                        light.push(m as u16);
                        irradiance.push(*e);
                        wi.push(l);
                        wo.push(local([0.0, 0.0, 1.0]));
                    }
                }
                pixels += 1;
            }
        }
        Sphere { pixels: pixels as usize, pixel, light, irradiance, wi, wo }
    }

    /// The pairs as the fit's samples, to evaluate a model at. A light's pairs share its theta_d (wi.wo
    /// is the light's direction against the camera's), and their lobe nodes are its theta_d at `NODES`
    /// values of theta_h (uniform in sqrt(theta_h), MERL's spacing), each pair at the nearest: the
    /// lobe C, a convolution of the NDF with the diffraction lobe, varies over a node's step (at most
    /// 4e-4 rad where theta_h < 0.1) by under 2 % at the sharpest lobe the tables hold (beta 0.005).
    pub fn data(&self) -> Data {
        let geometry: Vec<Geometry> = (0..self.wi.len())
            .into_par_iter()
            .map(|n| {
                let (theta_h, _) = lobe_node(self.wi[n], self.wo[n]);
                let q = ((theta_h / FRAC_PI_2).max(0.0).sqrt() * (NODES - 1) as f64).round() as usize;
                Geometry::of(self.wi[n], self.wo[n], self.light[n] as usize * NODES + q.min(NODES - 1))
            })
            .collect();
        let lights = lights();
        let nodes = (0..lights.len() * NODES)
            .map(|m| {
                // cos theta_d = cos(angle between wi and wo / 2) = sqrt((1 + wi.wo) / 2)
                let cos_d = ((1.0 + lights[m / NODES].0[2]) / 2.0).sqrt();
                ((((m % NODES) as f64) / (NODES - 1) as f64).powi(2) * FRAC_PI_2, cos_d)
            })
            .collect();
        Data::directions(geometry, nodes)
    }

    /// The image, one RGB value per sphere pixel, of the BRDF whose rho per channel at pair n is `rho[n]`.
    pub fn render(&self, rho: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut image = vec![[0.0; 3]; self.pixels];
        for (n, r) in rho.iter().enumerate() {
            let (px, e, cos_i) = (self.pixel[n] as usize, self.irradiance[n], self.wi[n][2]);
            for ch in 0..3 {
                image[px][ch] += e[ch] * r[ch] * cos_i;
            }
        }
        image
    }

    /// The image of a measured file as its renderer sees it: Mitsuba's `measured` plugin evaluates an RGL
    /// file with its incident direction towards the camera (its si.wi) and the outgoing one towards the light
    /// (`measured::File::rho` takes them in that order); a MERL file is reciprocal.
    pub fn render_file(&self, file: &File) -> Vec<[f64; 3]> {
        self.render_fn(|light, camera| file.rho(camera, light))
    }

    /// The image of a BRDF given as a function of (wi, wo): wi towards the light, wo towards the camera.
    pub fn render_fn(&self, rho: impl Fn([f64; 3], [f64; 3]) -> [f64; 3] + Sync) -> Vec<[f64; 3]> {
        let values: Vec<[f64; 3]> = (0..self.wi.len()).into_par_iter().map(|n| rho(self.wi[n], self.wo[n])).collect();
        self.render(&values)
    }
}

impl Sphere {
    /// The image as rows of RGB pixels, `resolution` square (0 off the sphere), from its sphere pixels.
    pub fn picture(&self, resolution: usize, image: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; resolution * resolution];
        let mut next = image.iter();
        for row in 0..resolution {
            for col in 0..resolution {
                let x = 2.0 * (col as f64 + 0.5) / resolution as f64 - 1.0;
                let y = 1.0 - 2.0 * (row as f64 + 0.5) / resolution as f64;
                if x * x + y * y < 1.0 {
                    out[row * resolution + col] = *next.next().expect("one value per sphere pixel");
                }
            }
        }
        out
    }
}

/// A picture's 8-bit encoding of radiance: scaled so that the 99th percentile of `reference`'s positive
/// values is white (every image of a picture alike), clamped, then sRGB-encoded.
pub fn srgb_exposure(reference: &[[f64; 3]]) -> impl Fn(f64) -> u8 {
    let mut values: Vec<f64> = reference.iter().flatten().copied().filter(|v| *v > 0.0).collect();
    values.sort_by(f64::total_cmp);
    let white = values.get(values.len() * 99 / 100).copied().unwrap_or(1.0).max(1e-12);
    move |v: f64| {
        let x = (v / white).clamp(0.0, 1.0);
        let s = if x <= 0.0031308 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0).round() as u8
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// SMAPE of the image `f` against `t`: mean over pixels and channels of |f - t| / ((|f| + |t|) / 2),
/// those where both are 0 left out (from 0, equal, to 2, one of them 0).
pub fn smape(f: &[[f64; 3]], t: &[[f64; 3]]) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for (a, b) in f.iter().zip(t) {
        for ch in 0..3 {
            let (x, y) = (a[ch], b[ch]);
            if x != 0.0 || y != 0.0 {
                sum += (x - y).abs() / ((x.abs() + y.abs()) / 2.0);
                count += 1;
            }
        }
    }
    sum / count.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Lambertian BRDF rho = 1/pi renders as the cosine-weighted sum of the lights, which for the sky
    /// alone at the sphere's top approaches its irradiance integral; and SMAPE's ends.
    #[test]
    fn a_lambertian_sphere_renders_its_irradiance() {
        let sphere = Sphere::new(32);
        // The pixel count is the disk's area in pixels, pi r^2, to a ring of pixels.
        assert!((sphere.pixels as f64 - PI * 256.0).abs() < 2.0 * PI * 16.0);
        let image = sphere.render_fn(|_, _| [1.0 / PI; 3]);
        // Every pixel at least sees some sky (its normal has z > 0 and the sky covers y > 0): all > 0.
        assert!(image.iter().all(|p| p.iter().all(|&v| v > 0.0)));
        // Each pair's cos_i is its light's direction against the pixel's normal: recompute one pixel's sum.
        let lights = lights();
        let (x, y): (f64, f64) = (2.0 * 16.5 / 32.0 - 1.0, 1.0 - 2.0 * 10.5 / 32.0);
        let n = [x, y, (1.0 - x * x - y * y).sqrt()];
        let want: f64 = lights.iter().map(|(d, e)| e[2] * dot(*d, n).max(0.0) / PI).filter(|v| *v > 0.0).sum();
        let row_start: usize = (0..10)
            .map(|r| {
                (0..32)
                    .filter(|&c| {
                        let (x, y) = (2.0 * (c as f64 + 0.5) / 32.0 - 1.0, 1.0 - 2.0 * (r as f64 + 0.5) / 32.0);
                        x * x + y * y < 1.0
                    })
                    .count()
            })
            .sum();
        let first_in_row = (0..32).position(|c| ((2.0 * (c as f64 + 0.5) / 32.0 - 1.0).powi(2) + y * y) < 1.0).unwrap();
        let got = image[row_start + 16 - first_in_row][2];
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        assert_eq!(smape(&image, &image), 0.0);
        let zero = vec![[0.0; 3]; image.len()];
        assert_eq!(smape(&zero, &image), 2.0);
        let double: Vec<[f64; 3]> = image.iter().map(|p| p.map(|v| 2.0 * v)).collect();
        assert!((smape(&double, &image) - 2.0 / 3.0).abs() < 1e-12);
    }
}
