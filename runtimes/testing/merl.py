"""Synthetic MERL BRDF files of a two-scale conductor (docs/maths.md section 7), from the brute-force reference.py
(no table of the project): the targets of `twoscale fit`'s tests (docs/fit.md "How it is checked").

The file (MERL's BRDFRead.cpp, docs/fit.md "The file"): three int32 dimensions (90, 90, 180), then the red, green
and blue blocks of 90 x 90 x 180 float64, all little-endian; sample (i, j, k) at index k + 180 (j + 90 i) holds
rho / scale, the scales 1/1500, 1.15/1500 and 1.66/1500. It stands at theta_h = (i/90)^2 pi/2, theta_d = j pi/180,
phi_d = k pi/180: h at (theta_h, phi_h = 0), wi the difference vector d = (sin theta_d cos phi_d, sin theta_d
sin phi_d, cos theta_d) rotated by theta_h about y (MERL's half_diff_coords_to_std_coords), so wi.h = cos theta_d,
and wo = 2 (wi.h) h - wi. A sample whose wi_z or wo_z is below 1e-6 (below the horizon, or so close to it that
1 / cos theta means nothing) is not valid: written as -1 in all three channels, which a MERL reader skips.

rho = F (spec + diff) of reference.brdf at each channel's own wavelength and complex index, computed on the grid's
structure rather than sample by sample (reference.brdf at 4.4 million samples would take days): D on the 90
theta_h, A and F on the 90 theta_d, the lobe C on the 90 x 90 (theta_h, theta_d) pairs of each channel, Lambda and R
per sample from interpolants of reference.smith_lambda and reference.renorm (relative error below 1e-8). C, a
function of theta_h and u = B cos theta_d, is interpolated in u from reference.lobe_c at Chebyshev points (lobes).
The lobes are the cost (a sharp lobe's 2,970 lobe_c about 7 s on 2 cores, where its 24,300 direct ones took 50 s; a
few seconds without diffraction): cached_conductor.

    python runtimes/testing/merl.py --beta 0.1 --p 1.2 --sigma-s 0.03 --b 1.5 --c 2.1 --eta 1.6,1.5,1.4 \\
        --k 3.2,3.0,2.8 [--wavelengths 0.65,0.55,0.45] [--noise 0.05 --seed 1] [--cache DIR] --out FILE.binary
"""
import argparse
import functools
import hashlib
import json
import math
import multiprocessing
import os
import sys
import time
from pathlib import Path

import numpy as np
import reference
from numpy.polynomial import Chebyshev
from scipy.interpolate import CubicSpline

DIMS = (90, 90, 180)
SCALES = np.array([1.0, 1.15, 1.66]) / 1500.0
HORIZON = 1e-6


def angles():
    """The grid's theta_h [90], theta_d [90] and phi_d [180]."""
    return (np.arange(90) / 90.0) ** 2 * (math.pi / 2), np.arange(90) * (math.pi / 180), np.arange(180) * (math.pi / 180)


@functools.cache
def directions():
    """(wi, wo, valid): wi, wo [90, 90, 180, 3] at every sample, valid [90, 90, 180] where wi_z, wo_z >= 1e-6. Made
    once per process (0.27 s; a fit test asks 3-4 times), read-only."""
    th, td, pd = np.meshgrid(*angles(), indexing="ij")
    dx, dy, dz = np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)
    wi = np.stack([dx * np.cos(th) + dz * np.sin(th), dy, dz * np.cos(th) - dx * np.sin(th)], -1)  # R_y(theta_h) d
    h = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    wo = 2.0 * (wi * h).sum(-1, keepdims=True) * h - wi
    out = wi, wo, (wi[..., 2] >= HORIZON) & (wo[..., 2] >= HORIZON)
    for a in out:
        a.flags.writeable = False
    return out


def smith_lambda_at(p, nodes=3000):
    """Lambda(p, a) at arrays of a >= 0. Lambda vanishes like exp(-mu^(2p)), mu = 1/a, so what is interpolated
    (cubic spline in x = ln a) is ln Lambda + mu^(2p), smooth at both ends, over [a_0, 1e6] (beta <= 0.5 and
    cos theta >= 1e-6 keep a below 5e5); below a_0, where mu^(2p) = 50, Lambda < 1e-18 is 0."""
    lo = -math.log(50.0) / (2.0 * p)
    x = np.linspace(lo, math.log(1e6), nodes)
    lam = np.array([reference.smith_lambda(p, a) for a in np.exp(x)])
    spline = CubicSpline(x, np.log(lam) + np.exp(-2.0 * p * x))

    def at(a):
        x = np.maximum(np.log(np.maximum(a, 1e-300)), lo)
        return np.where(x > lo, np.exp(spline(x) - np.exp(-2.0 * p * x)), 0.0)

    return at


def renorm_at(bb, c):
    """R(s, B, c) at arrays of s in [0, 1]: the Chebyshev interpolant of reference.renorm, its degree doubled until
    the last 8 coefficients fall below 1e-12 of the first. R is analytic in s, its nearest singularities 1/B off
    s = 1 (the disk's rim through the PSD's poles |g| = i/B): degree 32 for B <= 1, 128 at B = 44, 256 at B = 100."""
    for deg in 2 ** np.arange(5, 12):
        cheb = Chebyshev.interpolate(lambda s: np.array([reference.renorm(x, bb, c) for x in s]), int(deg), domain=[0, 1])
        if np.abs(cheb.coef[-8:]).max() < 1e-12 * abs(cheb.coef[0]):
            return cheb
    raise RuntimeError(f"R(s, {bb}, {c}): no Chebyshev interpolant of degree up to {deg}")


# lobe_c's relative tolerance: against its default 1e-7, 0-50 % less CPU time on 900 lobes of each of synthetic.py's 6 materials,
# C within 2.2e-7 of it (the largest: p = 0.3).
LOBE_REL = 1e-6


def lobes(theta_h, u, c, p, beta, workers, tail=1e-8):
    """C(theta_h[n], u[n]) of reference.lobe_c, by one Chebyshev interpolant of ln C in u over [0, max u] for each
    distinct theta_h. C > 0 is analytic in u (its integrand is in u^2, its branch points at |u| >= 1/2 off the real
    axis), so the interpolants converge geometrically: the degree, from 32, is doubled (Chebyshev-Lobatto points
    nest) until the last 4 coefficients of every row are below `tail`, an absolute error in ln C, so a relative one
    in C; if the lobe_c computed so far and the next doubling's would reach as many as there are points, C is
    computed at the points themselves (at most twice the direct cost). Measured on synthetic.py's conductors against
    lobe_c at 600 random points of their grids (LOBE_REL, lobe_c's own tolerance, is 1e-6): sharp within 1.6e-9
    (6 s on 2 cores where the 24,300 direct lobes took 50 s; its rho within 6.4e-8 of theirs at every sample),
    narrow 2.6e-8 (46 s; C from 4e-12 to 7e-3 of it), heavy 6.6e-8 (30 s)."""
    rows, row = np.unique(theta_h, return_inverse=True)
    u_max = float(np.max(u))
    with multiprocessing.Pool(workers) as pool:
        def at(pairs):  # chunks of 16 lobes, 0.05-0.5 s each: the costly ones, near theta_h = pi/2, spread out
            return np.array(pool.starmap(reference.lobe_c, [(th, uj, c, p, beta, LOBE_REL) for th, uj in pairs], chunksize=16))

        values, deg = None, 32
        while len(rows) * (deg + 1) < len(u):
            x = np.cos(np.pi * np.arange(deg + 1) / deg)  # Chebyshev-Lobatto points, those of deg / 2 at the even ones
            new = np.arange(deg + 1) if values is None else np.arange(1, deg + 1, 2)
            got = np.log(at([(th, 0.5 * u_max * (x[k] + 1.0)) for th in rows for k in new])).reshape(len(rows), -1)
            if values is None:
                values = got
            else:
                both = np.empty((len(rows), deg + 1))
                both[:, 0::2], both[:, 1::2] = values, got
                values = both
            coef = np.polynomial.chebyshev.chebfit(x, values.T, deg)  # [deg + 1, rows]
            if np.abs(coef[-4:]).max() <= tail:
                return np.exp(np.polynomial.chebyshev.chebval(2.0 * u / u_max - 1.0, coef[:, row], tensor=False))
            deg *= 2
        return at(zip(theta_h, u))


def conductor(beta, p, sigma_s, b, c, channels, workers=None):
    """rho [3, 90, 90, 180] (NaN where not valid) of the conductor (beta, p, sigma_s, b, c) of docs/maths.md section 7,
    channels [(lambda um, eta, k)] x 3: F (A D G2 / (4 cos_i cos_o) + (1 - A) G2 (c - 1) B^2 / (2 pi R) N(p)/beta^2 C),
    each factor by reference.py's own function: D on theta_h, A and F on theta_d, C on (theta_h, theta_d), G2 and R
    per sample (interpolated)."""
    theta_h, theta_d, _ = angles()
    cos_d = np.cos(theta_d)
    wi, wo, valid = directions()
    i, j, _ = np.nonzero(valid)
    cos_i, cos_o = wi[valid][:, 2], wo[valid][:, 2]
    lam_of = smith_lambda_at(p)
    g2 = 1.0 / (1.0 + sum(lam_of(beta * np.sqrt(1.0 - z * z) / z) for z in (cos_i, cos_o)))
    d = np.array([reference.ndf(ch, beta, p) for ch in np.cos(theta_h)])
    bbs = [b / lam for lam, _, _ in channels]
    if sigma_s > 0:  # C of each channel at the (i, j) with a valid sample
        ii, jj = np.nonzero(valid.any(2))
        lobe = np.zeros((3, 90, 90))
        u = np.concatenate([bb * cos_d[jj] for bb in bbs])
        lobe[:, ii, jj] = lobes(np.tile(theta_h[ii], 3), u, c, p, beta, workers or os.cpu_count()).reshape(3, -1)
    rho = np.full((3,) + DIMS, np.nan)
    for ch, ((lam, eta, k), bb) in enumerate(zip(channels, bbs)):
        a = np.exp(-((4.0 * math.pi * sigma_s * cos_d / lam) ** 2))
        value = a[j] * d[i] * g2 / (4.0 * cos_i * cos_o)
        if sigma_s > 0:
            r = renorm_at(bb, c)(np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0)))
            value += (1.0 - a[j]) * g2 * (c - 1.0) * bb * bb / (2.0 * math.pi * r) * reference.norm_p(p) / beta**2 * lobe[ch, i, j]
        rho[ch][valid] = reference.fresnel(cos_d, eta, k)[j] * value
    return rho


def cached_conductor(cache_dir, workers=None, **params):
    """conductor(**params), stored in cache_dir as a .npy named by a hash of the parameters and of the source of
    reference.py and of this file (what rho is computed from), and read from there when present."""
    text = json.dumps(params, sort_keys=True) + Path(reference.__file__).read_text() + Path(__file__).read_text()
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    path = Path(cache_dir) / f"conductor-{hashlib.sha256(text.encode()).hexdigest()[:20]}.npy"
    if path.exists():
        return np.load(path)
    rho = conductor(workers=workers, **params)
    write_atomically(path, lambda f: np.save(f, rho))
    return rho


def write_atomically(path, write_to):
    """Write path by write_to(file object) under a temporary name beside it, then rename: no reader (another test
    process) ever sees half a file."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        write_to(f)
    os.replace(tmp, path)


def write(path, rho, noise=0.0, seed=0):
    """The MERL file of rho [3, 90, 90, 180], NaN samples as -1; with noise, each valid sample and channel times
    1 + noise N(0, 1) (numpy's default_rng(seed)), clipped at 0. Written to a temporary name, then renamed."""
    rho = np.array(rho, dtype=np.float64)
    if rho.shape != (3,) + DIMS:
        raise ValueError(f"rho of shape {rho.shape}, not (3, 90, 90, 180)")
    if noise:
        rho = np.maximum(rho * (1.0 + noise * np.random.default_rng(seed).standard_normal(rho.shape)), 0.0)
    stored = np.where(np.isnan(rho), -1.0, rho / SCALES[:, None, None, None])
    write_atomically(Path(path), lambda f: f.write(np.array(DIMS, "<i4").tobytes() + stored.astype("<f8").tobytes()))


def read(path):
    """rho [3, 90, 90, 180] of a MERL file, NaN where the stored value is negative."""
    raw = Path(path).read_bytes()
    if tuple(np.frombuffer(raw[:12], "<i4")) != DIMS or len(raw) != 12 + 3 * 8 * math.prod(DIMS):
        raise ValueError(f"{path}: not a 90 x 90 x 180 MERL file")
    stored = np.frombuffer(raw[12:], "<f8").reshape((3,) + DIMS)
    return np.where(stored < 0, np.nan, stored * SCALES[:, None, None, None])


def triple(text):
    """R,G,B: three numbers."""
    values = [float(x) for x in text.split(",")]
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"{text!r}: three numbers R,G,B")
    return values


def main():
    ap = argparse.ArgumentParser(description="Write the MERL file of a synthetic two-scale conductor (reference.py).")
    for name in ("beta", "p", "sigma-s", "b", "c"):
        ap.add_argument(f"--{name}", type=float, required=True)
    ap.add_argument("--eta", type=triple, required=True, help="R,G,B")
    ap.add_argument("--k", type=triple, required=True, help="R,G,B")
    ap.add_argument("--wavelengths", type=triple, default=[0.65, 0.55, 0.45], help="R,G,B in micrometres")
    ap.add_argument("--noise", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", type=Path, help="a folder where rho is kept between runs")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    start = time.perf_counter()
    params = dict(beta=args.beta, p=args.p, sigma_s=args.sigma_s, b=args.b, c=args.c, channels=list(zip(args.wavelengths, args.eta, args.k)))
    rho = cached_conductor(args.cache, **params) if args.cache else conductor(**params)
    write(args.out, rho, args.noise, args.seed)
    print(f"{args.out}: {time.perf_counter() - start:.1f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
