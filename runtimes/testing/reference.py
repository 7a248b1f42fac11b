"""Brute-force docs/maths.md section 7, independent of the tables and of twoscale_model.py.

G1 and R by adaptive quadrature of their integrals (docs/maths.md sections 2 and 3), C by the direct
2-D integral of docs/maths.md section 4 over the microfacet normal m, N(p) and D in closed form, the
Fresnel factor in complex arithmetic. Slow (a C is a nested quadrature): for tests only.
"""
import math

import numpy as np
from scipy.integrate import quad
from scipy.special import gamma

EPS = 1e-10


def norm_p(p):
    """N(p) = p / (pi Gamma(1/p))."""
    return p / (math.pi * gamma(1.0 / p))


def ndf(cos_h, beta, p):
    tan2 = (1.0 - cos_h * cos_h) / (cos_h * cos_h)
    return norm_p(p) / beta**2 * math.exp(-((tan2 / beta**2) ** p)) / cos_h**4


def smith_lambda(p, a):
    """Lambda(p, a) = int_mu^inf 2 (sqrt(rho^2 - mu^2)/mu - acos(mu/rho)) N(p) exp(-rho^(2p)) rho drho,
    mu = 1/a, in rho = mu cosh y (sqrt(rho^2 - mu^2) = mu sinh y, acos(mu/rho) = atan(sinh y))."""
    if a == 0.0:
        return 0.0
    mu = 1.0 / a
    rho_max = 800.0 ** (1.0 / (2.0 * p))  # exp(-800) is nothing
    if rho_max <= mu:
        return 0.0
    y_max = math.acosh(rho_max / mu)

    def f(y):
        sh = math.sinh(y)
        rho = mu * math.cosh(y)
        return 2.0 * (sh - math.atan(sh)) * math.exp(-(rho ** (2.0 * p))) * rho * mu * sh

    pts = [math.acosh(1.0 / mu)] if mu < 1.0 else []
    val, _ = quad(f, 0.0, y_max, points=pts or None, epsabs=0.0, epsrel=EPS, limit=400)
    return norm_p(p) * val


def g1(p, cos_t, beta):
    tan_t = math.sqrt(max(1.0 - cos_t * cos_t, 0.0)) / cos_t
    return 1.0 / (1.0 + smith_lambda(p, beta * tan_t))


def renorm(s, bb, c):
    """R(s, B, c) of docs/maths.md section 3: the inner disk in closed form plus the ring's arcs."""
    inner = -math.expm1((1.0 - c) / 2.0 * math.log1p((bb * (1.0 - s)) ** 2))
    if s == 0.0:
        return inner

    def f(x):
        arg = min(max((x * x - 1.0 + s * s) / (2.0 * s * x), -1.0), 1.0)
        return math.acos(arg) * x * (1.0 + bb * bb * x * x) ** (-(c + 1.0) / 2.0)

    lo, hi = 1.0 - s, 1.0 + s
    pts = [x for x in (1.0 / bb,) if lo < x < hi]
    ring, _ = quad(f, lo, hi, points=pts or None, epsabs=0.0, epsrel=EPS, limit=400)
    return inner + (c - 1.0) * bb * bb / math.pi * ring


def lobe_c(theta_h, u, c, p, beta, rel=1e-7):
    """C(theta_h) = int S(h.m) D(n.m) dm over the hemisphere of m (S, D of docs/maths.md section 4),
    m = (theta_m, phi) about n, h at (theta_h, 0); 1 - (h.m)^2 from the haversine of their angle."""
    sh = math.sin(theta_h)

    def inner(tm):
        st = math.sin(tm)
        hav0 = math.sin((theta_h - tm) / 2.0) ** 2

        def s_of(phi):
            hav = hav0 + sh * st * math.sin(phi / 2.0) ** 2
            t = 1.0 - 2.0 * hav
            if t <= 0.0:
                return 0.0
            return (1.0 + 16.0 * u * u * hav * (1.0 - hav)) ** (-(c + 1.0) / 2.0) * t * t

        # S is narrow (angular width ~ 1/(2u)) about phi = 0 when m is near h.
        w = min(math.pi, 4.0 / (2.0 * u * max(sh * st, 1e-300)) if u > 0 else math.pi)
        pts = [w / 8, w] if w < math.pi else None
        val, _ = quad(s_of, 0.0, math.pi, points=pts, epsabs=0.0, epsrel=rel, limit=400)
        ct = math.cos(tm)
        d = math.exp(-((math.tan(tm) / beta) ** (2.0 * p))) / ct**4
        return 2.0 * val * d * st

    # D has width ~ beta (in tan theta_m), S its peak at theta_m = theta_h, width ~ 1/(2u).
    t_d = math.atan(beta * 30.0 ** (1.0 / (2.0 * p)))  # beyond it, D < exp(-900)
    w_s = 1.0 / (2.0 * u + 1e-300)
    pts = sorted({x for x in (theta_h - 4 * w_s, theta_h, theta_h + 4 * w_s, math.atan(beta), t_d) if 0.0 < x < math.pi / 2})
    val, _ = quad(inner, 0.0, math.pi / 2, points=pts or None, epsabs=0.0, epsrel=rel, limit=400)
    return val


def fresnel(cos_t, eta, k):
    """Unpolarised conductor Fresnel reflectance, complex index n = eta + i k."""
    n2 = complex(eta, k) ** 2
    sin2 = 1.0 - cos_t * cos_t
    root = np.sqrt(n2 - sin2)
    rs = (cos_t - root) / (cos_t + root)
    rp = (n2 * cos_t - root) / (n2 * cos_t + root)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


def brdf(wi, wo, lam, beta, p, sigma_s, b, c, eta=None, k=None):
    """(specular, diffraction, lobe peak) of docs/maths.md section 7 for one (wi, wo, lambda) with F = 1, and F.
    The lobe peak is the diffraction part with C replaced by max over theta_h of C: the scale the
    tables' lobe accuracy is measured against."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    cos_i, cos_o, cos_h, cos_d = wi[2], wo[2], h[2], float(wi @ h)
    lam_i, lam_o = 1.0 / g1(p, cos_i, beta) - 1.0, 1.0 / g1(p, cos_o, beta) - 1.0
    g2 = 1.0 / (1.0 + lam_i + lam_o)
    a = math.exp(-((4.0 * math.pi * sigma_s * cos_d / lam) ** 2))
    spec = a * ndf(cos_h, beta, p) * g2 / (4.0 * cos_i * cos_o)
    diff = peak = 0.0
    if sigma_s > 0:
        bb = b / lam
        r = renorm(math.sqrt(max(1.0 - cos_i * cos_i, 0.0)), bb, c)
        scale = (1.0 - a) * g2 * (c - 1.0) * bb * bb / (2.0 * math.pi * r) * norm_p(p) / beta**2
        u = bb * cos_d
        diff = scale * lobe_c(math.acos(min(cos_h, 1.0)), u, c, p, beta)
        peak = scale * lobe_c(0.0, u, c, p, beta)
    f = 1.0 if eta is None else fresnel(cos_d, eta, k)
    return spec, diff, peak, f
