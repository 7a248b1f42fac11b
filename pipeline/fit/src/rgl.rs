//! RGL-EPFL measured isotropic BRDF files (Dupuy and Jakob 2018, "An Adaptive Parameterization for
//! Efficient Material Acquisition and Rendering"), the RGB `*_rgb.bsdf` files Mitsuba 3's `measured`
//! plugin reads, evaluated as that plugin does (in f64).
//!
//! The container is a `tensor_file`, little-endian: the magic `tensor_file\0`, a u8 major and a u8
//! minor version (1.0), a u32 field count, then per field a u16 name length and the name, a u16 rank,
//! a u8 type (Mitsuba's struct type codes: 1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32,
//! 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64), a u64 offset of its data from the file's
//! start and a u64 per dimension (C order). The fields read, with T incidences and an n x n grid:
//! `description` (uint8 text), `phi_i` [1] (one: isotropic), `theta_i` [T] (increasing, radians),
//! `ndf` and `sigma` [rows, columns] (over (phi, theta) as u coordinates), `vndf` [1, T, rows,
//! columns], `luminance` [1, T, n, n], `rgb` [1, T, 3, n, n], `jacobian` (uint8 [1]) and `valid`
//! (uint8 [ceil(T n n / 8)]), all float32 but these three; `version` (uint32 [2], 1 0) is not read.
//!
//! The coordinates (Mitsuba's `measured`): theta = u^2 pi/2 (u = sqrt(theta / (pi/2))), phi =
//! (2 u - 1) pi. A direction pair (wi, wo) has the microfacet normal m = (wi + wo)/|wi + wo| at
//! u_m = (u(theta_m), u(phi_m - phi_i) mod 1); the VNDF's warp for wi's theta_i (`Warp`, Mitsuba's
//! continuous `Marginal2D`) maps a point of the unit square, the sample space, to u_m, and the file
//! holds its values on the sample space's n x n grid (nodes at (x, y)/(n - 1), x along the columns,
//! which map to theta_m, y along the rows, to phi_m). So rho(wi, wo) cos theta_o = the grid's
//! bilinear value at the inverse warp of u_m, times ndf(u_m) / (4 sigma(u_i)) where the `jacobian`
//! flag is set (all 14 files here). Between incidences, the warp's data and CDFs and the grid's values
//! are linear in theta_i (Mitsuba's parameter interpolation).
//!
//! `valid` is a bit per node of the (theta_i, y, x) grid in C order, the most significant bit of each
//! byte first. In the 14 files of the shared data it marks exactly the nodes whose wo (the node's
//! warped direction) is above the horizon, at every theta_i below 90 degrees; but in five
//! (colodur_connemara_4c, colodur_napoli_4f, paper_white, satin_rosaline, vch_ultra_pink) a set bit
//! marks a node below it. The reader takes the polarity under which the bits agree with the horizon
//! at more nodes (`Rgl::valid_inverted`). Invalid nodes hold 0 or other values (most of them 0 in
//! the matte files, few in chm_mint): no measurement of a pair above the horizon. A valid node's value
//! can be negative (an RGB colour outside the gamut of the spectral measurement: chm_mint down to
//! -0.62 against its peak 30, cc_ibiza_sunset, irid_flake_paint2, vch_ultra_pink a little).

use anyhow::{bail, Context, Result};
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// The cosine below which `samples` counts a direction below the horizon, as `merl::MIN_COS`: the
/// stored value is f cos theta_o, and at theta_i's last node (89.999996 degrees in these files, cos
/// 7.5e-8) wo reflects to cos 7.5e-8 at theta_m = 0, where value / cos theta_o reaches 1e7 to 1e11.
pub const MIN_COS: f64 = 1e-6;

/// The file's first 12 bytes.
const MAGIC: &[u8; 12] = b"tensor_file\0";

/// Mitsuba's struct type codes: (name, bytes per element), code 1 first.
const DTYPES: [(&str, usize); 11] = [
    ("uint8", 1),
    ("int8", 1),
    ("uint16", 2),
    ("int16", 2),
    ("uint32", 4),
    ("int32", 4),
    ("uint64", 8),
    ("int64", 8),
    ("float16", 2),
    ("float32", 4),
    ("float64", 8),
];
const UINT8: u8 = 1;
const FLOAT16: u8 = 9;
const FLOAT32: u8 = 10;
const FLOAT64: u8 = 11;

fn dtype_name(code: u8) -> &'static str {
    DTYPES.get((code as usize).wrapping_sub(1)).map_or("unknown", |d| d.0)
}

/// One field of the file: its name, type, shape and data (in bounds).
struct Field<'a> {
    name: String,
    dtype: u8,
    shape: Vec<usize>,
    data: &'a [u8],
}

/// A name from the file, printable on one line.
fn quoted(name: &str) -> String {
    name.escape_debug().to_string()
}

/// Reads the header and the field table; every field's data must lie in the file.
fn fields(bytes: &[u8]) -> Result<Vec<Field<'_>>> {
    if bytes.len() < 18 {
        bail!("{} bytes: not an RGL file (a tensor_file's 18-byte header first)", bytes.len());
    }
    if &bytes[..12] != MAGIC {
        bail!("not an RGL file: the first 12 bytes are not tensor_file\\0");
    }
    if (bytes[12], bytes[13]) != (1, 0) {
        bail!("tensor_file version {}.{}: twoscale reads version 1.0", bytes[12], bytes[13]);
    }
    let count = u32::from_le_bytes(bytes[14..18].try_into().unwrap());
    let mut at = 18usize;
    let mut take = |n: usize, k: u32, what: &str| -> Result<&[u8]> {
        let end = at.checked_add(n).filter(|&e| e <= bytes.len());
        let Some(end) = end else {
            bail!(
                "truncated field table: field {} of {count}'s {what} runs past the file's {} bytes",
                k + 1,
                bytes.len()
            )
        };
        let s = &bytes[at..end];
        at = end;
        Ok(s)
    };
    let mut out: Vec<Field> = Vec::new();
    for k in 0..count {
        let len = u16::from_le_bytes(take(2, k, "name length")?.try_into().unwrap()) as usize;
        let name = String::from_utf8_lossy(take(len, k, "name")?).into_owned();
        let rank = u16::from_le_bytes(take(2, k, "rank")?.try_into().unwrap()) as usize;
        let dtype = take(1, k, "type")?[0];
        let offset = u64::from_le_bytes(take(8, k, "offset")?.try_into().unwrap());
        let dims = take(8 * rank, k, "shape")?;
        let shape: Vec<u64> = dims.chunks_exact(8).map(|d| u64::from_le_bytes(d.try_into().unwrap())).collect();
        let field = quoted(&name);
        if !(1..=11).contains(&dtype) {
            bail!("field {field}: unknown type code {dtype} (1 to 11)");
        }
        if out.iter().any(|f| f.name == name) {
            bail!("field {field} twice in the field table");
        }
        // elements x element size, and the data's end, without overflow
        let size = DTYPES[dtype as usize - 1].1 as u64;
        let end = shape.iter().try_fold(size, |n, &d| n.checked_mul(d)).and_then(|n| n.checked_add(offset));
        match end {
            Some(end) if end <= bytes.len() as u64 => {
                let shape = shape.iter().map(|&d| d as usize).collect();
                out.push(Field { name, dtype, shape, data: &bytes[offset as usize..end as usize] })
            }
            _ => bail!(
                "field {field}: {} {shape:?} at byte {offset} lies beyond the file's {} bytes",
                dtype_name(dtype),
                bytes.len()
            ),
        }
    }
    Ok(out)
}

/// The field table, looked up by name.
struct Fields<'a>(Vec<Field<'a>>);

impl<'a> Fields<'a> {
    fn has(&self, name: &str) -> bool {
        self.0.iter().any(|f| f.name == name)
    }

    /// The field `name` of type `dtype`.
    fn get(&self, name: &str, dtype: u8) -> Result<&Field<'a>> {
        let Some(f) = self.0.iter().find(|f| f.name == name) else { bail!("no field {name}") };
        if f.dtype != dtype {
            bail!("field {name}: type {}, expected {}", dtype_name(f.dtype), dtype_name(dtype));
        }
        Ok(f)
    }
}

impl Field<'_> {
    fn expect_shape(&self, want: &[usize], what: &str) -> Result<()> {
        if self.shape != want {
            bail!("field {}: shape {:?}, expected {want:?} ({what})", self.name, self.shape);
        }
        Ok(())
    }

    fn expect_rank(&self, rank: usize, what: &str) -> Result<()> {
        if self.shape.len() != rank {
            bail!("field {}: shape {:?}, expected {rank} dimensions ({what})", self.name, self.shape);
        }
        Ok(())
    }

    /// The index of element `flat` (C order), for messages.
    fn index_of(&self, mut flat: usize) -> Vec<usize> {
        let mut index = vec![0; self.shape.len()];
        for (i, &d) in self.shape.iter().enumerate().rev() {
            if d > 0 {
                index[i] = flat % d;
                flat /= d;
            }
        }
        index
    }

    /// A float32 field's values, each finite.
    fn floats(&self) -> Result<Vec<f64>> {
        let v: Vec<f64> = self.data.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap()) as f64).collect();
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            bail!("field {}: {} at {:?}", self.name, v[i], self.index_of(i));
        }
        Ok(v)
    }

    /// The first value that is not finite, of a float field of any width: the value and its element.
    fn not_finite(&self) -> Option<(String, usize)> {
        let size = match self.dtype {
            FLOAT16 => 2,
            FLOAT32 => 4,
            FLOAT64 => 8,
            _ => return None,
        };
        self.data.chunks_exact(size).enumerate().find_map(|(at, b)| {
            let value = match size {
                // exponent bits all set: an infinity or a NaN
                2 => u16::from_le_bytes(b.try_into().unwrap()),
                4 => {
                    return (!f32::from_le_bytes(b.try_into().unwrap()).is_finite())
                        .then(|| (f32::from_le_bytes(b.try_into().unwrap()).to_string(), at))
                }
                _ => {
                    return (!f64::from_le_bytes(b.try_into().unwrap()).is_finite())
                        .then(|| (f64::from_le_bytes(b.try_into().unwrap()).to_string(), at))
                }
            };
            (value & 0x7c00 == 0x7c00).then(|| (format!("float16 0x{value:04x}"), at))
        })
    }
}

/// Linear weights between two neighbouring slices of a parameter (Mitsuba's
/// `Distribution2D::interpolate_weights` over theta_i): value = w0 slice[k] + w1 slice[k + stride].
#[derive(Clone, Copy, Debug)]
struct Blend {
    k: usize,
    stride: usize,
    w: [f64; 2],
}

impl Blend {
    /// The slices' blend at theta in the nodes `nodes` (increasing): the interval [k, k + 1] is the
    /// first whose upper node is >= theta (the first, or the last interval outside the nodes), w1 =
    /// (theta - node k)/(node k+1 - node k) clamped to [0, 1]; one node: that slice alone.
    fn at(nodes: &[f64], theta: f64) -> Blend {
        let n = nodes.len();
        if n < 2 {
            return Blend { k: 0, stride: 0, w: [1.0, 0.0] };
        }
        let upper = 1 + nodes[1..n - 1].partition_point(|&v| v < theta);
        let k = upper - 1;
        let w1 = ((theta - nodes[k]) / (nodes[k + 1] - nodes[k])).clamp(0.0, 1.0);
        Blend { k, stride: 1, w: [1.0 - w1, w1] }
    }

    /// Element `i` of the blend of `a`'s slices of `per` values, slice k being `a`'s slice k scale + extra
    /// (the spectra's slices are (theta_i, channel): scale 3, extra the channel).
    fn of(&self, a: &[f64], per: usize, scale: usize, extra: usize, i: usize) -> f64 {
        let s0 = self.k * scale + extra;
        let s1 = (self.k + self.stride) * scale + extra;
        self.w[0] * a[s0 * per + i] + self.w[1] * a[s1 * per + i]
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Cell and fraction of a coordinate in [0, 1] on a grid of `size` nodes (nodes at i/(size - 1)):
/// the cell min(floor(x (size - 1)), size - 2), clamped into the grid.
fn cell(x: f64, size: usize) -> (usize, f64) {
    // (a NaN x gives cell 0: `as usize` saturates)
    let p = x.clamp(0.0, 1.0) * (size - 1) as f64;
    let i = (p.floor() as usize).min(size - 2);
    (i, p - i as f64)
}

/// Bilinear interpolants on slices of an h x w grid over the unit square (x along the w columns):
/// Mitsuba's `Marginal2D::eval` without normalisation.
struct Grid {
    w: usize,
    h: usize,
    data: Vec<f64>,
}

impl Grid {
    /// The bilinear value at `pos` of the blend of slices (slice index k scale + extra).
    fn eval(&self, blend: &Blend, scale: usize, extra: usize, pos: [f64; 2]) -> f64 {
        let ((x, fx), (y, fy)) = (cell(pos[0], self.w), cell(pos[1], self.h));
        let v = |dx: usize, dy: usize| blend.of(&self.data, self.w * self.h, scale, extra, (y + dy) * self.w + x + dx);
        lerp(lerp(v(0, 0), v(1, 0), fx), lerp(v(0, 1), v(1, 1), fx), fy)
    }
}

/// Mitsuba's continuous `Marginal2D` (`Continuous = true`, normalised) over slices of an h x w density
/// grid on the unit square: the density d is bilinear between the nodes; the marginal in y and the
/// conditional in x are piecewise linear integrals of it. Per slice, with dx = 1/(w - 1) and dy = 1/(h - 1):
/// - cond[j][i] = sum over i' <= i of (d[j][i'] + d[j][i' + 1]) dx / 2, the integral of row j from
///   x = 0 to node i + 1 (w - 1 values per row);
/// - marg[j] = sum over j' <= j of (cond[j'][w-2] + cond[j' + 1][w-2]) dy / 2, the integral up to
///   row j + 1 (h - 1 values);
/// - all three divided by marg[h-2], the slice's integral.
struct Warp {
    w: usize,
    h: usize,
    data: Vec<f64>,
    cond: Vec<f64>,
    marg: Vec<f64>,
}

impl Warp {
    /// The warp of `slices` h x w slices of `d`; each slice must integrate to more than 0.
    fn new(d: &[f64], w: usize, h: usize, slices: usize) -> std::result::Result<Warp, usize> {
        let (dx, dy) = (1.0 / (w - 1) as f64, 1.0 / (h - 1) as f64);
        let (mut data, mut cond, mut marg) = (
            Vec::with_capacity(d.len()),
            Vec::with_capacity(slices * h * (w - 1)),
            Vec::with_capacity(slices * (h - 1)),
        );
        for s in 0..slices {
            let d = &d[s * w * h..(s + 1) * w * h];
            let mut c = Vec::with_capacity(h * (w - 1));
            for j in 0..h {
                let mut acc = 0.0;
                for i in 0..w - 1 {
                    acc += 0.5 * dx * (d[j * w + i] + d[j * w + i + 1]);
                    c.push(acc);
                }
            }
            let mut m = Vec::with_capacity(h - 1);
            let mut acc = 0.0;
            for j in 0..h - 1 {
                acc += 0.5 * dy * (c[j * (w - 1) + w - 2] + c[(j + 1) * (w - 1) + w - 2]);
                m.push(acc);
            }
            if !(acc > 0.0 && (1.0 / acc).is_finite()) {
                return Err(s);
            }
            data.extend(d.iter().map(|v| v / acc));
            cond.extend(c.iter().map(|v| v / acc));
            marg.extend(m.iter().map(|v| v / acc));
        }
        Ok(Warp { w, h, data, cond, marg })
    }

    fn d(&self, b: &Blend, i: usize) -> f64 {
        b.of(&self.data, self.w * self.h, 1, 0, i)
    }

    /// cond[row][i], blended.
    fn c(&self, b: &Blend, row: usize, i: usize) -> f64 {
        b.of(&self.cond, self.h * (self.w - 1), 1, 0, row * (self.w - 1) + i)
    }

    fn m(&self, b: &Blend, j: usize) -> f64 {
        b.of(&self.marg, self.h - 1, 1, 0, j)
    }

    /// The fraction t in [0, 1] of a segment of width 1/inv_width with density lerp(v0, v1, t) up to
    /// which it holds `mass`: (v0 t + (v1 - v0) t^2/2)/inv_width = mass, solved as
    /// t = a/(v0 + sqrt(v0^2 + a (v1 - v0))), a = 2 mass inv_width (stable for v0 = v1). Mitsuba's
    /// `sample_segment` takes the linear approximation where they differ by less than 1e-4 of their
    /// sum, which its eval, an inverse, does not: this is the exact inverse of `segment_mass`.
    fn segment(mass: f64, inv_width: f64, v0: f64, v1: f64) -> f64 {
        let a = 2.0 * mass * inv_width;
        let den = v0 + (v0 * v0 + a * (v1 - v0)).max(0.0).sqrt();
        if den > 0.0 {
            (a / den).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The mass of a segment of width `width` with density lerp(v0, v1, t) up to t:
    /// t lerp(v0, v1, t/2) width (Mitsuba's `invert_segment`).
    fn segment_mass(t: f64, width: f64, v0: f64, v1: f64) -> f64 {
        t * lerp(v0, v1, 0.5 * t) * width
    }

    /// The warp of a sample point p of the unit square to u (Mitsuba's `sample_continuous`): y first,
    /// by the marginal (its row: the first whose CDF reaches p.y; within it the segment), then x by the
    /// conditional at that y, the rows' CDFs interpolated linearly in y. Returns u in [0, 1]^2.
    fn sample(&self, b: &Blend, p: [f64; 2]) -> [f64; 2] {
        let (w, h) = (self.w, self.h);
        let (mut x, mut y) = (p[0].clamp(0.0, 1.0), p[1].clamp(0.0, 1.0));
        // row: the first j in [0, h - 2] with marg[j] >= y, else h - 2
        let (mut lo, mut hi) = (0, h - 2);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.m(b, mid) < y {
                lo = mid + 1
            } else {
                hi = mid
            }
        }
        let row = lo;
        if row > 0 {
            y -= self.m(b, row - 1);
        }
        // the rows' totals, and the fraction within the row's segment
        let (r0, r1) = (self.c(b, row, w - 2), self.c(b, row + 1, w - 2));
        let ty = Warp::segment(y, (h - 1) as f64, r0, r1);
        // x: the conditional at ty, whose total is lerp(r0, r1, ty)
        x *= lerp(r0, r1, ty);
        let cdf = |i: usize| lerp(self.c(b, row, i), self.c(b, row + 1, i), ty);
        // column: the first i in [0, w - 2] with cdf(i) >= x (Mitsuba may return w - 1 when rounding
        // puts x past the row's total, and then reads the next row's first node: clamped here)
        let (mut lo, mut hi) = (0, w - 2);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if cdf(mid) < x {
                lo = mid + 1
            } else {
                hi = mid
            }
        }
        let col = lo;
        if col > 0 {
            x -= cdf(col - 1);
        }
        let at = |i: usize, j: usize| self.d(b, j * w + i);
        let c0 = lerp(at(col, row), at(col, row + 1), ty);
        let c1 = lerp(at(col + 1, row), at(col + 1, row + 1), ty);
        let tx = Warp::segment(x, (w - 1) as f64, c0, c1);
        [(col as f64 + tx) / (w - 1) as f64, (row as f64 + ty) / (h - 1) as f64]
    }

    /// The inverse warp of u to the sample point (Mitsuba's `invert_continuous`): in u's cell, x = (the
    /// conditional's mass left of the cell + the cell's mass up to u.x) / the row's total at u.y, y =
    /// the marginal's mass below the cell + the cell's up to u.y. A row without density (total 0)
    /// gives x = 0 (Mitsuba: 0/0).
    fn invert(&self, b: &Blend, u: [f64; 2]) -> [f64; 2] {
        let (w, h) = (self.w, self.h);
        let ((i, fx), (j, fy)) = (cell(u[0], w), cell(u[1], h));
        let at = |i: usize, j: usize| self.d(b, j * w + i);
        let c0 = lerp(at(i, j), at(i, j + 1), fy);
        let c1 = lerp(at(i + 1, j), at(i + 1, j + 1), fy);
        let mut x = Warp::segment_mass(fx, 1.0 / (w - 1) as f64, c0, c1);
        if i > 0 {
            x += lerp(self.c(b, j, i - 1), self.c(b, j + 1, i - 1), fy);
        }
        let (r0, r1) = (self.c(b, j, w - 2), self.c(b, j + 1, w - 2));
        let total = lerp(r0, r1, fy);
        x = if total > 0.0 { x / total } else { 0.0 };
        let mut y = Warp::segment_mass(fy, 1.0 / (h - 1) as f64, r0, r1);
        if j > 0 {
            y += self.m(b, j - 1);
        }
        [x, y]
    }
}

/// theta = u^2 pi/2.
fn u2theta(u: f64) -> f64 {
    u * u * FRAC_PI_2
}

/// phi = (2 u - 1) pi.
fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}

/// u = sqrt(theta / (pi/2)).
fn theta2u(theta: f64) -> f64 {
    (theta / FRAC_PI_2).sqrt()
}

/// u = (phi + pi) / (2 pi).
fn phi2u(phi: f64) -> f64 {
    (phi + PI) / (2.0 * PI)
}

/// The elevation of a unit vector, 2 asin(|d - z| / 2): acos(d.z) without its loss of precision near
/// the normal (Mitsuba's `elevation`).
fn elevation(d: [f64; 3]) -> f64 {
    let dist = (d[0] * d[0] + d[1] * d[1] + (d[2] - 1.0) * (d[2] - 1.0)).sqrt();
    2.0 * (0.5 * dist).min(1.0).asin()
}

/// An RGL-EPFL measured isotropic BRDF, RGB.
pub struct Rgl {
    /// The file's `description`.
    pub description: String,
    /// The incident elevations of the slices, radians, increasing (f32 values).
    pub theta_i: Vec<f64>,
    /// The file's `jacobian` flag (1 in all 14 files): the stored value times ndf(u_m) / (4 sigma(u_i))
    /// is f cos theta_o; unset, the stored value alone is.
    pub jacobian: bool,
    /// The `valid` bits' polarity: true where a set bit marks a node below the horizon (5 of the 14
    /// files), taken as the polarity under which the bits agree with the nodes' horizon more often.
    pub valid_inverted: bool,
    /// The nodes with wi above the horizon whose bit, read in that polarity, says otherwise of wo's
    /// horizon (cos theta >= `MIN_COS`): 0 in the 14 files.
    pub valid_mismatches: usize,
    /// The sample space's grid: n x n nodes per incidence and channel.
    pub n: usize,
    ndf: Grid,
    sigma: Grid,
    vndf: Warp,
    /// [theta_i][channel] slices of n x n
    rgb: Grid,
    valid: Vec<u8>,
}

/// One measured node of the file: its directions and rho.
#[derive(Clone, Copy, Debug)]
pub struct RglSample {
    /// (theta_i, y, x): the incidence, then the row (phi_m's axis) and column (theta_m's) of the
    /// sample space's grid, as in the `rgb` field's [0, theta_i, channel, y, x].
    pub index: [usize; 3],
    /// Unit vectors in the local frame (z the normal): wi at theta_i and phi_i = 0, the file's
    /// incident direction (Mitsuba's si.wi), and wo.
    pub wi: [f64; 3],
    pub wo: [f64; 3],
    /// rho (1/sr) per channel, red, green, blue.
    pub rho: [f64; 3],
    /// The solid-angle measure dwi dwo the node stands for (`Rgl::measure`).
    pub measure: f64,
}

/// Reads and checks an RGL file: every error is one line naming the file.
pub fn read(path: &Path) -> Result<Rgl> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse(&bytes).with_context(|| format!("{}", path.display()))
}

/// `read` on the file's bytes: the checks Mitsuba's `TensorFile` and `measured` make (the header, the
/// types, the ranks, the sizes shared between fields, every 2D grid at least 2 x 2), and besides them
/// every field's data inside the file, no field twice, no NaN or infinity in any float field, theta_i
/// increasing in [0, 90] degrees, `valid` of one bit per node, sigma positive, ndf, vndf and luminance
/// not negative and each incidence's VNDF integrating to more than 0. A spectral file and an
/// anisotropic one are refused.
pub fn parse(bytes: &[u8]) -> Result<Rgl> {
    let fields = Fields(fields(bytes)?);
    if fields.has("wavelengths") || fields.has("spectra") {
        bail!("a spectral RGL file: twoscale fit reads the RGB ones (*_rgb.bsdf)");
    }
    let phi_i = fields.get("phi_i", FLOAT32)?;
    phi_i.expect_rank(1, "the incident azimuths")?;
    if phi_i.shape[0] > 1 {
        bail!(
            "an anisotropic RGL file ({} incident azimuths phi_i): twoscale fit reads isotropic ones",
            phi_i.shape[0]
        );
    }
    phi_i.expect_shape(&[1], "one incident azimuth: isotropic")?;
    let theta_f = fields.get("theta_i", FLOAT32)?;
    theta_f.expect_rank(1, "the incident elevations")?;
    let t = theta_f.shape[0];
    if t == 0 {
        bail!("field theta_i: shape [0], expected at least one incident elevation");
    }
    let rgb_f = fields.get("rgb", FLOAT32)?;
    let n = rgb_f.shape.get(3).copied().unwrap_or(0).max(2);
    rgb_f.expect_shape(&[1, t, 3, n, n], "phi_i, theta_i, red green blue, a square grid of at least 2 x 2")?;
    let lum_f = fields.get("luminance", FLOAT32)?;
    lum_f.expect_shape(&[1, t, n, n], "phi_i, theta_i, the rgb field's grid")?;
    let vndf_f = fields.get("vndf", FLOAT32)?;
    let grid = |f: &Field, lead: &[usize], what: &str| -> Result<(usize, usize)> {
        f.expect_rank(lead.len() + 2, what)?;
        let (h, w) = (f.shape[lead.len()], f.shape[lead.len() + 1]);
        f.expect_shape(&[lead, &[h.max(2), w.max(2)]].concat(), what)?;
        Ok((h, w))
    };
    let (vh, vw) = grid(vndf_f, &[1, t], "phi_i, theta_i, a grid of at least 2 x 2 over (phi_m, theta_m)")?;
    let ndf_f = fields.get("ndf", FLOAT32)?;
    let (nh, nw) = grid(ndf_f, &[], "a grid of at least 2 x 2 over (phi_m, theta_m)")?;
    let sigma_f = fields.get("sigma", FLOAT32)?;
    let (sh, sw) = grid(sigma_f, &[], "a grid of at least 2 x 2 over (phi_i, theta_i)")?;
    let description = fields.get("description", UINT8)?;
    description.expect_rank(1, "text")?;
    let jacobian = fields.get("jacobian", UINT8)?;
    jacobian.expect_shape(&[1], "a flag")?;
    let valid_f = fields.get("valid", UINT8)?;
    valid_f.expect_shape(&[(t * n * n).div_ceil(8)], "a bit per node of the theta_i x grid nodes")?;
    // A NaN or an infinity in any float field, read or not.
    for f in &fields.0 {
        if let Some((value, at)) = f.not_finite() {
            bail!("field {}: {value} at {:?}", quoted(&f.name), f.index_of(at));
        }
    }
    let theta_i = theta_f.floats()?;
    // f32 pi/2 is 4.4e-8 above pi/2
    if let Some(k) =
        (0..t).find(|&k| !(0.0..=FRAC_PI_2 + 1e-6).contains(&theta_i[k]) || (k > 0 && theta_i[k] <= theta_i[k - 1]))
    {
        bail!("field theta_i: {} at [{k}]: not increasing in [0, pi/2]", theta_i[k]);
    }
    let not_negative = |f: &Field, v: &[f64]| -> Result<()> {
        match v.iter().position(|&x| x < 0.0) {
            Some(i) => bail!("field {}: {} at {:?}, a density: not negative", f.name, v[i], f.index_of(i)),
            None => Ok(()),
        }
    };
    let ndf = ndf_f.floats()?;
    not_negative(ndf_f, &ndf)?;
    let sigma = sigma_f.floats()?;
    if let Some(i) = sigma.iter().position(|&x| x <= 0.0) {
        bail!("field sigma: {} at {:?}, a projected area: positive", sigma[i], sigma_f.index_of(i));
    }
    let vndf = vndf_f.floats()?;
    not_negative(vndf_f, &vndf)?;
    not_negative(lum_f, &lum_f.floats()?)?;
    let vndf = match Warp::new(&vndf, vw, vh, t) {
        Ok(w) => w,
        Err(s) => {
            bail!("field vndf: the slice of theta_i [{s}] integrates to 0 (or overflows): no distribution to warp")
        }
    };
    let mut rgl = Rgl {
        description: String::from_utf8_lossy(description.data).into_owned(),
        theta_i,
        jacobian: jacobian.data[0] != 0,
        valid_inverted: false,
        valid_mismatches: 0,
        n,
        ndf: Grid { w: nw, h: nh, data: ndf },
        sigma: Grid { w: sw, h: sh, data: sigma },
        vndf,
        rgb: Grid { w: n, h: n, data: rgb_f.floats()? },
        valid: valid_f.data.to_vec(),
    };
    // The polarity: the bits against wo's horizon at the nodes of the incidences above it.
    let (mut agree, mut disagree) = (0usize, 0usize);
    for k in 0..t {
        for y in 0..n {
            for x in 0..n {
                let Some((wi, wo, _)) = rgl.node(k, y, x) else { continue };
                if wi[2] >= MIN_COS {
                    if rgl.bit(k, y, x) == (wo[2] >= MIN_COS) {
                        agree += 1
                    } else {
                        disagree += 1
                    }
                }
            }
        }
    }
    rgl.valid_inverted = disagree > agree;
    rgl.valid_mismatches = agree.min(disagree);
    Ok(rgl)
}

impl Rgl {
    /// Bit (k, y, x) of `valid`: flat index (k n + y) n + x, the most significant bit of a byte first.
    fn bit(&self, k: usize, y: usize, x: usize) -> bool {
        let i = (k * self.n + y) * self.n + x;
        self.valid[i / 8] >> (7 - i % 8) & 1 == 1
    }

    /// Whether the file marks node (k, y, x) valid.
    pub fn valid(&self, k: usize, y: usize, x: usize) -> bool {
        self.bit(k, y, x) != self.valid_inverted
    }

    fn blend(&self, theta_i: f64) -> Blend {
        Blend::at(&self.theta_i, theta_i)
    }

    /// ndf(u_m) / (4 sigma(u_i)) where the `jacobian` flag is set, else 1.
    fn jacobian_factor(&self, u_m: [f64; 2], u_i: [f64; 2]) -> f64 {
        if !self.jacobian {
            return 1.0;
        }
        let one = Blend { k: 0, stride: 0, w: [1.0, 0.0] };
        self.ndf.eval(&one, 1, 0, u_m) / (4.0 * self.sigma.eval(&one, 1, 0, u_i))
    }

    /// Node (k, y, x)'s directions and u_m (`at`). None for an index outside the grid.
    fn node(&self, k: usize, y: usize, x: usize) -> Option<([f64; 3], [f64; 3], [f64; 2])> {
        let n = self.n;
        if k >= self.theta_i.len() || y >= n || x >= n {
            return None;
        }
        Some(self.at(k, [x as f64 / (n - 1) as f64, y as f64 / (n - 1) as f64]))
    }

    /// The directions and u_m at the sample point p of incidence k: wi = (sin theta_i, 0, cos theta_i)
    /// (phi_i = 0), m at u_m = the VNDF warp of p, theta_m = u2theta(u_m.x), phi_m = u2phi(u_m.y) +
    /// phi_i, and wo = 2 (wi.m) m - wi.
    fn at(&self, k: usize, p: [f64; 2]) -> ([f64; 3], [f64; 3], [f64; 2]) {
        let theta = self.theta_i[k];
        let wi = [theta.sin(), 0.0, theta.cos()];
        let u = self.vndf.sample(&self.blend(theta), p);
        let (theta_m, phi_m) = (u2theta(u[0]), u2phi(u[1]));
        let m = [phi_m.cos() * theta_m.sin(), phi_m.sin() * theta_m.sin(), theta_m.cos()];
        let im = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2];
        let wo = [2.0 * im * m[0] - wi[0], 2.0 * im * m[1] - wi[1], 2.0 * im * m[2] - wi[2]];
        (wi, wo, u)
    }

    /// The solid-angle measure dwi dwo node (k, y, x) stands for: dwo = |d wo/d p_x x d wo/d p_y| / (n -
    /// 1)^2, the warp's Jacobian by central differences (one-sided at the square's edges), halved on each
    /// edge of the square the node lies on (the trapezoid rule: an edge node stands for half a cell), and dwi the
    /// band of incidences closer to theta_i[k] than to its neighbours, cos theta_lo - cos theta_hi (the
    /// azimuth's 2 pi left out: every sample shares it).
    fn measure(&self, k: usize, y: usize, x: usize) -> f64 {
        const H: f64 = 1e-4;
        let step = 1.0 / (self.n - 1) as f64;
        let p = [x as f64 * step, y as f64 * step];
        let derivative = |axis: usize| {
            let (mut lo, mut hi) = (p, p);
            lo[axis] = (p[axis] - H).max(0.0);
            hi[axis] = (p[axis] + H).min(1.0);
            let (a, b) = (self.at(k, lo).1, self.at(k, hi).1);
            [0, 1, 2].map(|c| (b[c] - a[c]) / (hi[axis] - lo[axis]))
        };
        let (dx, dy) = (derivative(0), derivative(1));
        let cross = [dx[1] * dy[2] - dx[2] * dy[1], dx[2] * dy[0] - dx[0] * dy[2], dx[0] * dy[1] - dx[1] * dy[0]];
        let edge = |i: usize| if i == 0 || i == self.n - 1 { 0.5 } else { 1.0 };
        let d_wo =
            (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt() * step * step * edge(x) * edge(y);
        let t = &self.theta_i;
        let lo = if k == 0 { 0.0 } else { 0.5 * (t[k - 1] + t[k]) };
        let hi = if k + 1 == t.len() { FRAC_PI_2 } else { 0.5 * (t[k] + t[k + 1]) };
        d_wo * (lo.cos() - hi.min(FRAC_PI_2).cos())
    }

    /// The file's measured nodes: each node marked valid whose wi and wo are above the horizon (cos
    /// theta >= `MIN_COS`: no node of the last incidence, 90 degrees but for f32 rounding), in
    /// (theta_i, y, x) order, with rho = the stored value x the Jacobian factor at the node's u_m /
    /// cos theta_o. The nodes at x = 0 (theta_m = 0: one direction pair for every y) and y = n - 1
    /// (phi_m = pi, the direction pair of y = 0) hold measurements of direction pairs other nodes
    /// share; `rho` returns one value there (the other nodes' rho is `rho` at their directions).
    pub fn samples(&self) -> Vec<RglSample> {
        let n = self.n;
        let mut out = Vec::new();
        for k in 0..self.theta_i.len() {
            let theta = self.theta_i[k];
            // u_i = (theta2u(theta_i), phi2u(0))
            let u_i = [theta2u(theta), 0.5];
            for y in 0..n {
                for x in 0..n {
                    if !self.valid(k, y, x) {
                        continue;
                    }
                    let Some((wi, wo, u_m)) = self.node(k, y, x) else { continue };
                    if !(wi[2] >= MIN_COS && wo[2] >= MIN_COS) {
                        continue;
                    }
                    let f = self.jacobian_factor(u_m, u_i) / wo[2];
                    let rho = [0, 1, 2].map(|c| self.rgb.data[((k * 3 + c) * n + y) * n + x] * f);
                    out.push(RglSample { index: [k, y, x], wi, wo, rho, measure: self.measure(k, y, x) });
                }
            }
        }
        out
    }

    /// rho (1/sr, not times a cosine) per channel at unit vectors (wi, wo), z the normal, as Mitsuba's
    /// `measured` evaluates the file with si.wi = wi (the file's incident direction, whose elevation
    /// selects the slices) and its wo = wo, divided by cos theta_o (Mitsuba's eval is f cos theta_o);
    /// 0 where wi or wo is at or below the horizon. With m = (wi + wo)/|wi + wo|:
    /// u_i = (theta2u(theta_i), phi2u(phi_i)), u_m = (theta2u(theta_m), phi2u(phi_m - phi_i) mod 1),
    /// the sample point s = the VNDF warp's inverse at u_m for theta_i, and rho = rgb(s) x the Jacobian
    /// factor ndf(u_m) / (4 sigma(u_i)) / cos theta_o, rgb and the warp blended linearly in theta_i.
    /// The bilinear interpolation of a negative node's neighbourhood can be negative. At wi = (0, 0, 1)
    /// phi_i = atan2(0, 0) = 0, the limit along phi_i = 0 (the installed Mitsuba reads phi_m + pi
    /// there where wi.y is +0: tests/suite/fit/rgl.rs).
    pub fn rho(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        if !(wi[2] > 0.0 && wo[2] > 0.0) {
            return [0.0; 3];
        }
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let norm = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let m = s.map(|v| v / norm);
        let (theta_i, phi_i) = (elevation(wi), wi[1].atan2(wi[0]));
        let (theta_m, phi_m) = (elevation(m), m[1].atan2(m[0]));
        let u_i = [theta2u(theta_i), phi2u(phi_i)];
        let y = phi2u(phi_m - phi_i);
        let u_m = [theta2u(theta_m), y - y.floor()];
        let blend = self.blend(theta_i);
        let p = self.vndf.invert(&blend, u_m);
        let f = self.jacobian_factor(u_m, u_i) / wo[2];
        [0, 1, 2].map(|c| self.rgb.eval(&blend, 3, c, p) * f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tensor_file of `fields`: (name, type code, shape, data bytes), the data after the table.
    fn tensor_file(fields: &[(&str, u8, Vec<u64>, Vec<u8>)]) -> Vec<u8> {
        let table: usize = fields.iter().map(|(name, _, shape, _)| 2 + name.len() + 2 + 1 + 8 + 8 * shape.len()).sum();
        let mut out = MAGIC.to_vec();
        out.extend([1u8, 0]);
        out.extend((fields.len() as u32).to_le_bytes());
        let mut offset = 18 + table;
        for (name, dtype, shape, data) in fields {
            out.extend((name.len() as u16).to_le_bytes());
            out.extend(name.as_bytes());
            out.extend((shape.len() as u16).to_le_bytes());
            out.push(*dtype);
            out.extend((offset as u64).to_le_bytes());
            for d in shape {
                out.extend(d.to_le_bytes());
            }
            offset += data.len();
        }
        for (_, _, _, data) in fields {
            out.extend(data);
        }
        out
    }

    fn f32s(v: impl IntoIterator<Item = f64>) -> Vec<u8> {
        v.into_iter().flat_map(|x| (x as f32).to_le_bytes()).collect()
    }

    type Fields = Vec<(&'static str, u8, Vec<u64>, Vec<u8>)>;

    /// A small synthetic RGL file: 3 incidences (0, 35, 70 degrees), a 5 x 5 grid, a 6-row x 7-column
    /// VNDF (a rough lobe around the normal, leaning with theta_i), smooth positive values, every bit
    /// of `valid` set (or none: `bits`).
    fn synthetic(bits: u8) -> Fields {
        let (t, n, vh, vw) = (3usize, 5usize, 6usize, 7usize);
        let theta = [0.0, 35f64.to_radians(), 70f64.to_radians()];
        let mut vndf = Vec::new();
        for k in 0..t {
            for j in 0..vh {
                let phi = u2phi(j as f64 / (vh - 1) as f64);
                for i in 0..vw {
                    let tm = u2theta(i as f64 / (vw - 1) as f64);
                    vndf.push((-(tm / 0.6).powi(2)).exp() * (1.0 + 0.4 * theta[k].sin() * phi.cos()) + 0.02);
                }
            }
        }
        let ndf: Vec<f64> = (0..2 * 8).map(|i| 1.0 + (-((i % 8) as f64 / 3.0).powi(2)).exp()).collect();
        let sigma: Vec<f64> = (0..2 * 4).map(|i| 0.9 + 0.05 * (i % 4) as f64).collect();
        let rgb: Vec<f64> =
            (0..t * 3 * n * n).map(|i| 0.2 + 0.1 * (i % 7) as f64 + 0.05 * (i / (n * n)) as f64).collect();
        let lum: Vec<f64> = (0..t * n * n).map(|i| 0.5 + (i % 3) as f64).collect();
        let t64 = t as u64;
        vec![
            ("version", 5, vec![2], [1u32, 0].iter().flat_map(|v| v.to_le_bytes()).collect()),
            ("description", UINT8, vec![9], b"synthetic".to_vec()),
            ("phi_i", FLOAT32, vec![1], f32s([0.0])),
            ("theta_i", FLOAT32, vec![t64], f32s(theta)),
            ("sigma", FLOAT32, vec![2, 4], f32s(sigma)),
            ("ndf", FLOAT32, vec![2, 8], f32s(ndf)),
            ("vndf", FLOAT32, vec![1, t64, vh as u64, vw as u64], f32s(vndf)),
            ("luminance", FLOAT32, vec![1, t64, n as u64, n as u64], f32s(lum)),
            ("rgb", FLOAT32, vec![1, t64, 3, n as u64, n as u64], f32s(rgb)),
            ("jacobian", UINT8, vec![1], vec![1]),
            ("valid", UINT8, vec![(t * n * n).div_ceil(8) as u64], vec![bits; (t * n * n).div_ceil(8)]),
        ]
    }

    fn set(fields: &mut Fields, name: &str, dtype: u8, shape: Vec<u64>, data: Vec<u8>) {
        let f = fields.iter_mut().find(|f| f.0 == name).unwrap();
        (f.1, f.2, f.3) = (dtype, shape, data);
    }

    #[test]
    fn the_measure_sums_to_the_solid_angle_reflection_covers() {
        // At normal incidence wo = 2 (wi . wm) wm - wi takes the hemisphere of wm onto the whole sphere
        // once: the nodes' dwo sum to 4 pi, within 15 % on 5 x 5 nodes (a factor of 2 astray fails; the
        // shared files' test, tests/suite/fit/rgl.rs, measures the sum on real grids).
        let mut fields = synthetic(0xff);
        // a flat VNDF, whose warp is smooth enough for 5 x 5 nodes
        set(&mut fields, "vndf", FLOAT32, vec![1, 3, 6, 7], f32s(vec![1.0; 3 * 6 * 7]));
        let rgl = parse(&tensor_file(&fields)).unwrap();
        let band = 1.0 - (0.5 * rgl.theta_i[1]).cos();
        let n = rgl.n;
        let total: f64 = (0..n).flat_map(|y| (0..n).map(move |x| (y, x))).map(|(y, x)| rgl.measure(0, y, x)).sum();
        let relative = total / band / (4.0 * std::f64::consts::PI) - 1.0;
        assert!(relative.abs() < 0.15, "sum of dwo at normal incidence: 4 pi (1 {relative:+.3})");
    }

    #[test]
    fn the_warp_and_its_inverse_round_trip() {
        let rgl = parse(&tensor_file(&synthetic(0xff))).unwrap();
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        for _ in 0..20_000 {
            // at the incidences and between them
            let blend = rgl.blend(uniform() * 75f64.to_radians());
            let p = [uniform(), uniform()];
            let u = rgl.vndf.sample(&blend, p);
            let q = rgl.vndf.invert(&blend, u);
            let back = rgl.vndf.sample(&blend, q);
            worst = worst.max((q[0] - p[0]).abs().max((q[1] - p[1]).abs())).max((back[0] - u[0]).abs());
        }
        assert!(worst < 1e-12, "sample(invert(sample(p))): {worst:e}");
        // The corners and edges of the square.
        for p in [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0], [0.5, 0.0], [0.0, 0.5]] {
            let blend = rgl.blend(0.3);
            let q = rgl.vndf.invert(&blend, rgl.vndf.sample(&blend, p));
            assert!((q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12, "{p:?} -> {q:?}");
        }
    }

    /// The warp pushes the uniform measure on the square to the VNDF's density: a histogram of the
    /// warped points over u against the normalised bilinear density (a check on sample, not only on
    /// the pair's consistency).
    #[test]
    fn the_warp_samples_the_density() {
        let rgl = parse(&tensor_file(&synthetic(0xff))).unwrap();
        let blend = rgl.blend(0.4);
        let (w, h) = (rgl.vndf.w, rgl.vndf.h);
        let grid = Grid { w, h, data: rgl.vndf.data.clone() };
        let cells = 4usize;
        let mut count = vec![0usize; cells * cells];
        let m = 400;
        for a in 0..m {
            for b in 0..m {
                let u = rgl.vndf.sample(&blend, [(a as f64 + 0.5) / m as f64, (b as f64 + 0.5) / m as f64]);
                let (i, j) =
                    (((u[0] * cells as f64) as usize).min(cells - 1), ((u[1] * cells as f64) as usize).min(cells - 1));
                count[j * cells + i] += 1;
            }
        }
        for j in 0..cells {
            for i in 0..cells {
                // the density's integral over the cell (midpoint rule, 20 x 20)
                let mut mass = 0.0;
                for a in 0..20 {
                    for b in 0..20 {
                        let u = [
                            (i as f64 + (a as f64 + 0.5) / 20.0) / cells as f64,
                            (j as f64 + (b as f64 + 0.5) / 20.0) / cells as f64,
                        ];
                        mass += grid.eval(&blend, 1, 0, u) / (400.0 * (cells * cells) as f64);
                    }
                }
                let got = count[j * cells + i] as f64 / (m * m) as f64;
                assert!((got - mass).abs() < 2e-3, "cell ({i}, {j}): {got} of the points, {mass} of the mass");
            }
        }
    }

    /// A node's stored value, as `samples` gives it, is what `rho` returns at its directions, but at
    /// the nodes whose direction pair another node has (x = 0, y = n - 1).
    #[test]
    fn samples_are_rho_at_their_own_directions() {
        for bits in [0xff, 0x00] {
            let rgl = parse(&tensor_file(&synthetic(bits))).unwrap();
            assert_eq!(rgl.valid_inverted, bits == 0);
            let samples = rgl.samples();
            // theta_i = 0 and 35 degrees: every node above the horizon; 70 degrees: some below
            assert!(samples.len() > 2 * 25 && samples.len() < 3 * 25, "{}", samples.len());
            let mut checked = 0;
            for s in &samples {
                let [k, y, x] = s.index;
                let stored = rgl.rgb.data[((k * 3) * 5 + y) * 5 + x];
                assert!(s.rho[0] != 0.0 && stored > 0.0);
                if x == 0 || y == rgl.n - 1 {
                    continue;
                }
                let r = rgl.rho(s.wi, s.wo);
                for c in 0..3 {
                    assert!(
                        (r[c] - s.rho[c]).abs() <= 1e-10 * s.rho[c].abs(),
                        "{:?} channel {c}: {} vs {}",
                        s.index,
                        r[c],
                        s.rho[c]
                    );
                }
                checked += 1;
            }
            assert!(checked >= 32, "{checked}");
        }
    }

    #[test]
    fn rho_is_zero_below_the_horizon_and_reciprocal_in_form() {
        let rgl = parse(&tensor_file(&synthetic(0xff))).unwrap();
        let (a, b) = ([0.3, 0.1, (1.0f64 - 0.1).sqrt()], [-0.5, 0.2, (1.0f64 - 0.29).sqrt()]);
        assert!(rgl.rho(a, b).iter().all(|&v| v > 0.0 && v.is_finite()));
        assert_eq!(rgl.rho([0.6, 0.0, -0.8], b), [0.0; 3]);
        assert_eq!(rgl.rho(a, [0.6, 0.0, 0.0]), [0.0; 3]);
        assert_eq!(rgl.rho([f64::NAN; 3], b), [0.0; 3]);
        // isotropic: a rotation of both about the normal changes nothing
        let rot = |v: [f64; 3]| [0.6 * v[0] - 0.8 * v[1], 0.8 * v[0] + 0.6 * v[1], v[2]];
        let (r0, r1) = (rgl.rho(a, b), rgl.rho(rot(a), rot(b)));
        assert!((0..3).all(|c| (r0[c] - r1[c]).abs() < 1e-12 * r0[c]), "{r0:?} {r1:?}");
    }

    #[test]
    fn bad_files_are_refused_with_one_line() {
        let good = tensor_file(&synthetic(0xff));
        let err = |b: &[u8]| {
            let e = parse(b).err().expect("refused").to_string();
            assert_eq!(e.lines().count(), 1, "{e}");
            e
        };
        let with = |edit: &dyn Fn(&mut Fields)| {
            let mut f = synthetic(0xff);
            edit(&mut f);
            err(&tensor_file(&f))
        };
        assert!(err(&good[..10]).contains("not an RGL file"));
        let mut magic = good.clone();
        magic[0] = b'T';
        assert!(err(&magic).contains("not an RGL file"));
        let mut version = good.clone();
        version[12] = 2;
        assert!(err(&version).contains("version 2.0"));
        // truncated: in the field table, then in the data
        assert!(err(&good[..40]).starts_with("truncated field table"));
        assert!(err(&good[..good.len() - 1]).contains("beyond the file's"));
        let mut count = good.clone();
        count[14] = 12;
        let e = err(&count);
        // the data's first bytes read as a 12th header: a field with an unknown type
        assert!(e.starts_with("field ") && e.ends_with("unknown type code 0 (1 to 11)"), "{e}");
        // types, shapes, values
        assert_eq!(
            with(&|f| set(f, "rgb", 11, vec![1, 3, 3, 5, 5], vec![0; 8 * 75 * 3])),
            "field rgb: type float64, expected float32"
        );
        assert!(with(&|f| set(f, "jacobian", 0, vec![1], vec![1])).contains("unknown type code 0"));
        assert_eq!(
            with(&|f| set(f, "rgb", FLOAT32, vec![1, 3, 3, 5, 4], vec![0; 4 * 3 * 3 * 20])),
            "field rgb: shape [1, 3, 3, 5, 4], expected [1, 3, 3, 5, 5] (phi_i, theta_i, red green blue, a square grid of at least 2 x 2)"
        );
        assert!(with(&|f| set(f, "luminance", FLOAT32, vec![1, 3, 4, 4], vec![0; 4 * 48]))
            .contains("expected [1, 3, 5, 5]"));
        assert!(with(&|f| set(f, "vndf", FLOAT32, vec![1, 2, 6, 7], vec![0; 4 * 84])).contains("expected [1, 3, 6, 7]"));
        assert!(with(&|f| set(f, "ndf", FLOAT32, vec![16], vec![0; 64])).contains("expected 2 dimensions"));
        assert!(with(&|f| set(f, "sigma", FLOAT32, vec![1, 8], vec![0; 32])).contains("expected [2, 8]"));
        assert!(with(&|f| set(f, "valid", UINT8, vec![8], vec![0; 8])).contains("expected [10]"));
        assert!(with(&|f| f.retain(|f| f.0 != "ndf")).contains("no field ndf"));
        let nan = with(&|f| {
            let mut rgb: Vec<u8> = f.iter().find(|f| f.0 == "rgb").unwrap().3.clone();
            rgb[4 * 30..4 * 31].copy_from_slice(&f32::NAN.to_le_bytes());
            set(f, "rgb", FLOAT32, vec![1, 3, 3, 5, 5], rgb)
        });
        // element 30 of [1, 3, 3, 5, 5]: channel 1, row 1, column 0
        assert_eq!(nan, "field rgb: NaN at [0, 0, 1, 1, 0]");
        assert!(with(&|f| f.push(("extra", FLOAT64, vec![1], f64::INFINITY.to_le_bytes().to_vec())))
            .contains("field extra: inf at [0]"));
        assert!(with(&|f| set(f, "theta_i", FLOAT32, vec![3], f32s([0.0, 0.5, 0.4]))).contains("not increasing"));
        assert!(with(&|f| set(f, "sigma", FLOAT32, vec![2, 4], f32s([1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0])))
            .contains("positive"));
        assert!(with(&|f| set(
            f,
            "vndf",
            FLOAT32,
            vec![1, 3, 6, 7],
            f32s((0..126).map(|i| if i < 42 { 0.0 } else { 1.0 }))
        ))
        .contains("slice of theta_i [0] integrates to 0"));
        assert!(with(&|f| set(f, "ndf", FLOAT32, vec![2, 8], f32s((0..16).map(|i| i as f64 - 1.0))))
            .contains("not negative"));
        assert!(with(&|f| f.push(("theta_i", FLOAT32, vec![3], f32s([0.0, 0.5, 1.0])))).contains("twice"));
        // spectral and anisotropic files
        let spectral = with(&|f| {
            f.retain(|f| f.0 != "rgb");
            f.push(("wavelengths", FLOAT32, vec![4], f32s([400.0, 500.0, 600.0, 700.0])));
            f.push(("spectra", FLOAT32, vec![1, 3, 4, 5, 5], f32s((0..300).map(|_| 0.5))));
        });
        assert_eq!(spectral, "a spectral RGL file: twoscale fit reads the RGB ones (*_rgb.bsdf)");
        let aniso = with(&|f| set(f, "phi_i", FLOAT32, vec![4], f32s([0.0, 0.5, 1.0, 1.5])));
        assert!(aniso.starts_with("an anisotropic RGL file (4 incident azimuths phi_i)"), "{aniso}");
        // a shape whose byte count overflows
        assert!(with(&|f| set(f, "luminance", FLOAT32, vec![1 << 40, 1 << 40], vec![])).contains("beyond the file's"));
    }

    /// Every prefix and every single-byte change of the header and the field table: an error or a
    /// file, never a panic.
    #[test]
    fn no_prefix_or_header_byte_panics() {
        let good = tensor_file(&synthetic(0xff));
        for len in 0..good.len() {
            let _ = parse(&good[..len]);
        }
        for at in 0..400.min(good.len()) {
            for v in [0u8, 1, 2, 0x7f, 0x80, 0xff] {
                let mut b = good.clone();
                b[at] = v;
                if let Ok(r) = parse(&b) {
                    let _ = r.samples();
                    assert!(r.rho([0.3, 0.1, 0.95], [-0.2, 0.1, 0.97]).iter().all(|v| v.is_finite()));
                }
            }
        }
    }
}
