"""MERL files of BRDFs outside the two-scale model's family (issue 63): a microfacet coat over a Lambertian base, what
many measured and rendered materials are written from, to see what `twoscale fit` makes of data it cannot fit
exactly (which model it picks, how far off, whether a parameter silently stands in for what is missing).

    rho = F(cos theta_d) D(theta_h) G2(wi, wo) / (4 cos_i cos_o) + kd / pi + constant,

- D: GGX (Trowbridge-Reitz), alpha^2 / (pi cos^4 theta_h (alpha^2 + tan^2 theta_h)^2), whose power-law tail no EPD
  has (the EPD with p = 1 is Beckmann, so a Beckmann coat alone is inside the family), Beckmann,
  exp(-tan^2 theta_h / alpha^2) / (pi alpha^2 cos^4 theta_h), or the EPD, N(p) / beta^2 exp(-(tan^2 theta_h /
  beta^2)^p) / cos^4 theta_h, N(p) = p / (pi Gamma(1/p)) (the two-scale conductor's own D: an EPD coat alone is its
  conductor without diffraction, so only the base puts the file outside the family);
- G2: Smith's height-correlated 1 / (1 + Lambda(wi) + Lambda(wo)), GGX's Lambda = (sqrt(1 + alpha^2 tan^2) - 1) / 2,
  Beckmann's (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)), a = 1 / (alpha tan theta), the EPD's
  reference.smith_lambda(p, beta tan theta) through merl.smith_lambda_at's spline;
- F: exact unpolarised Fresnel at the half vector, of a conductor (eta + i k per channel) or of a dielectric (ior);
- the base: a Lambertian kd per channel simply added (no energy exchange with the coat, as an artist's "specular
  plus diffuse" is written), and an optional constant rho (a grey offset: a Lambertian of albedo pi x constant).

Each `*_conductor_lambert` file is exactly a member of one of `twoscale fit --compare`'s comparison models (F of the
conductor per channel, D and G2 of the coat, kd / pi per channel): ggx_conductor_lambert of ggx_lambert,
beckmann_conductor_lambert of beckmann_lambert, epd_conductor_lambert of epd_lambert. So are the others: a dielectric
one with k = 0 (the conductor's F is then the dielectric's), ggx_conductor_constant with kd = pi x constant.

The samples' directions and the format are merl.py's (merl.directions, merl.write): NaN, written as -1, where wi or
wo is within 1e-6 of the horizon. Everything is numpy over the valid samples: a file takes a few seconds.

    python -m out_of_family --out DIR [--only NAME ...]     # DIR/NAME.binary for each of MATERIALS
"""
import argparse
import functools
import math
import sys
import time
from pathlib import Path

import merl
import numpy as np
from reference import norm_p
from scipy.special import erf

LAMBDAS = (0.65, 0.55, 0.45)  # the channels' wavelengths (micrometres): only names here, F is per channel

# name: (distribution, its parameters, under, kd per channel, constant). The parameters: (alpha,) of ggx and beckmann,
# (beta, p) of epd. under: ("conductor", eta[3], k[3]) or ("dielectric", ior).
MATERIALS = {
    # issue 63's first file: a GGX metal over a dark base (--compare's ggx_lambert)
    "ggx_conductor_lambert": ("ggx", (0.15,), ("conductor", (1.5, 1.2, 0.9), (3.2, 2.8, 2.5)), (0.05, 0.04, 0.03), 0.0),
    # issue 63's third: a GGX varnish over a coloured base
    "ggx_dielectric_lambert": ("ggx", (0.2,), ("dielectric", 1.5), (0.25, 0.12, 0.05), 0.0),
    # --compare's beckmann_lambert
    "beckmann_conductor_lambert": ("beckmann", (0.15,), ("conductor", (1.5, 1.2, 0.9), (3.2, 2.8, 2.5)), (0.05, 0.04, 0.03), 0.0),
    "beckmann_dielectric_lambert": ("beckmann", (0.2,), ("dielectric", 1.5), (0.25, 0.12, 0.05), 0.0),
    # --compare's epd_lambert: p 0.6, a heavy-tailed lobe (not a Beckmann), over ggx_conductor_lambert's metal and base
    "epd_conductor_lambert": ("epd", (0.1, 0.6), ("conductor", (1.5, 1.2, 0.9), (3.2, 2.8, 2.5)), (0.05, 0.04, 0.03), 0.0),
    # a GGX metal with a grey offset and no base: a measurement's floor
    "ggx_conductor_constant": ("ggx", (0.3,), ("conductor", (1.5, 1.2, 0.9), (3.2, 2.8, 2.5)), (0.0, 0.0, 0.0), 0.01),
}


def fresnel_conductor(cos_t, eta, k):
    """Unpolarised reflectance of a conductor of complex index eta + i k at arrays of cos_t (reference.fresnel's)."""
    n2 = complex(eta, k) ** 2
    root = np.sqrt(n2 - (1.0 - cos_t * cos_t))
    rs = (cos_t - root) / (cos_t + root)
    rp = (n2 * cos_t - root) / (n2 * cos_t + root)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


def fresnel_dielectric(cos_t, ior):
    """Unpolarised reflectance of a dielectric of index ior (from outside) at arrays of cos_t."""
    cos_r = np.sqrt(np.maximum(1.0 - (1.0 - cos_t * cos_t) / (ior * ior), 0.0))
    rs = (cos_t - ior * cos_r) / (cos_t + ior * cos_r)
    rp = (ior * cos_t - cos_r) / (ior * cos_t + cos_r)
    return 0.5 * (rs * rs + rp * rp)


def ndf(distribution, params, cos_h):
    """D(theta_h) of the distribution with parameters `params` (MATERIALS'), normalised so that int D cos theta_h dh = 1."""
    c2 = cos_h * cos_h
    tan2 = (1.0 - c2) / c2
    if distribution == "epd":
        beta, p = params
        return norm_p(p) / beta**2 * np.exp(-((tan2 / beta**2) ** p)) / (c2 * c2)
    a2 = params[0] ** 2
    if distribution == "ggx":
        return a2 / (math.pi * c2 * c2 * (a2 + tan2) ** 2)
    return np.exp(-tan2 / a2) / (math.pi * a2 * c2 * c2)


# The EPD's Lambda(p, a) by merl.smith_lambda_at (a cubic spline of ln Lambda + a^(-2p) in ln a on 3,000 nodes, 0.4 s
# to build). Against reference.smith_lambda at the 2,999 midpoints between nodes (a up to 1e6) and 500 random a up to
# 1e5, its relative error is at most 2.3e-13 at p = 0.6, 5.6e-12 at p = 1 (pipeline/fit/tests/test_epd_file.py checks
# it). Below the first node (a^(-2p) = 50) it returns 0 where Lambda < 3e-24 (p 0.6 and 1): G2 off by as little.
epd_lambda = functools.cache(merl.smith_lambda_at)


def smith_lambda(distribution, params, cos_t):
    """Smith's Lambda at arrays of cos_t > 0."""
    tan = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0)) / cos_t
    if distribution == "epd":
        beta, p = params
        return epd_lambda(p)(beta * tan)
    alpha = params[0]
    if distribution == "ggx":
        return 0.5 * (np.sqrt(1.0 + (alpha * tan) ** 2) - 1.0)
    a = 1.0 / np.maximum(alpha * tan, 1e-30)  # a^2 finite at normal incidence
    # exp(-a^2) / a underflows to 0 and erf(a) to 1 together where a is large: Lambda 0, as it should be
    return 0.5 * (erf(a) - 1.0) + np.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))


def rho(distribution, params, under, kd, constant=0.0):
    """rho [3, 90, 90, 180] of the coat over the base (NaN where merl.py's sample is not valid)."""
    wi, wo, valid = merl.directions()
    a, b = wi[valid], wo[valid]
    h = a + b
    h /= np.linalg.norm(h, axis=1)[:, None]
    cos_i, cos_o, cos_d = a[:, 2], b[:, 2], np.clip((a * h).sum(1), 0.0, 1.0)
    g2 = 1.0 / (1.0 + smith_lambda(distribution, params, cos_i) + smith_lambda(distribution, params, cos_o))
    coat = ndf(distribution, params, h[:, 2]) * g2 / (4.0 * cos_i * cos_o)
    out = np.full((3,) + merl.DIMS, np.nan)
    for ch in range(3):
        f = fresnel_conductor(cos_d, under[1][ch], under[2][ch]) if under[0] == "conductor" else fresnel_dielectric(cos_d, under[1])
        out[ch][valid] = f * coat + kd[ch] / math.pi + constant
    return out


def write(name, out_dir):
    """DIR/name.binary of MATERIALS[name]; its path."""
    path = Path(out_dir) / f"{name}.binary"
    merl.write(path, rho(*MATERIALS[name]))
    return path


def main():
    ap = argparse.ArgumentParser(description="Write MERL files of BRDFs outside the two-scale family (a microfacet coat over a Lambertian base).")
    ap.add_argument("--out", type=Path, required=True, help="the folder the files go to")
    ap.add_argument("--only", nargs="+", choices=sorted(MATERIALS), help="these materials only (default: all)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.only or MATERIALS:
        start = time.perf_counter()
        path = write(name, args.out)
        print(f"{path}: {time.perf_counter() - start:.1f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
