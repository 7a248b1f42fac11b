"""zh_lobe's control variates (docs/maths.md section 4b, docs/file_contract.md), over numpy arrays.

The table stores ln C at the nodes and the terms t_j at the nodes (values `cv_<term>`). A reader
interpolates all of them with the same cell weights I and adds, at the query point q,

    ln C(q) = I[ln C](q) + sum_j alpha_j(q) (t_j(q) - I[cv_j](q)),

terms j = ln_m_s, b, epd_core, tail. Each function mirrors pipeline/tables/src/lobe.rs.
"""
import math

import numpy as np

# The terms in the order the manifest lists them (and `correction` takes them).
TERMS = ("ln_m_s", "b", "epd_core", "tail")
# The physical coordinates of a table with control variates, theta_h derived (stored as v).
COORDINATES = ["u", "c", "p", "beta", "theta_h"]

LN_PI = math.log(math.pi)
FRAC_PI_2 = math.pi / 2


def _lgamma(x):
    """ln Gamma element-wise (math.lgamma once per distinct value: a render's points share p)."""
    distinct, which = np.unique(x, return_inverse=True)
    return np.array([math.lgamma(v) for v in distinct.tolist()], dtype=np.float64)[which.reshape(np.shape(x))]


def ln_m_s(u, c):
    """ln m_S(u, c) = ln(pi (1 - (1 + 4u^2)^((1-c)/2)) / (4u^2 (c-1)/2)); ln pi where 4u^2 < 1e-12."""
    a = 4.0 * u * u
    mass_inside = -np.expm1(0.5 * (1.0 - c) * np.log1p(a))
    return np.where(a < 1e-12, LN_PI, np.log(math.pi * mass_inside / (0.5 * a * (c - 1.0))))


def ln_m_d(p, beta):
    """ln m_D = ln(pi beta^2 Gamma(1 + 1/p))."""
    return 2.0 * np.log(beta) + LN_PI + _lgamma(1.0 / p) - np.log(p)


def slope_variance(p, beta):
    """s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p))."""
    return 0.5 * beta * beta * np.exp(_lgamma(2.0 / p) - _lgamma(1.0 / p))


def ln_d_smoothed(theta, u, p, beta):
    """ln D at e = min(sqrt(theta^2 + 1/(4 (1 + 4u^2))), pi/2): -(tan e / beta)^(2p) - 4 ln max(sin(pi/2 - e), 1e-300)."""
    e = np.minimum(np.sqrt(theta * theta + 0.25 / (1.0 + 4.0 * u * u)), FRAC_PI_2)
    return -np.power(np.tan(e) / beta, 2.0 * p) - 4.0 * np.log(np.maximum(np.sin(FRAC_PI_2 - e), 1e-300))


def logaddexp(a, b):
    """ln(e^a + e^b), b finite."""
    m = np.maximum(a, b)
    return m + np.log(np.exp(a - m) + np.exp(b - m))


def smoothstep(y, lo, hi):
    """3x^2 - 2x^3 of x = (y - lo) / (hi - lo) clamped to [0, 1]."""
    x = np.minimum(np.maximum((y - lo) / (hi - lo), 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def weights(u, p, beta, v):
    """alpha_j of TERMS at the query point (u, p, beta) and stored angle v:
    (1 - w)(lambda - mu), (1 - w)(1 - lambda), (1 - w) mu, w, where lambda = (wd2 / (ws2 + wd2))^2
    (ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2), mu = lambda^2 smoothstep(p, 0.3, 0.5) and
    w = smoothstep(v, 0.2, 0.5) (1 - smoothstep(-2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), -4, -1))."""
    ws2 = 1.0 / (1.0 + 4.0 * u * u)
    wd = beta / (2.0 * p)
    wd2 = wd * wd
    r = wd2 / (ws2 + wd2)
    lam = r * r
    mu = lam * lam * smoothstep(p, 0.3, 0.5)
    grazing_peak = -2.0 / p + 2.0 * np.log1p(beta * beta * np.power(2.0 / p, 1.0 / p))
    w = smoothstep(v, 0.2, 0.5) * (1.0 - smoothstep(grazing_peak, -4.0, -1.0))
    return [(1.0 - w) * (lam - mu), (1.0 - w) * (1.0 - lam), (1.0 - w) * mu, w]


def terms(theta, u, c, p, beta):
    """t_j of TERMS at the points: ln m_S, b, logaddexp(ln m_S + ln D, b'), logaddexp(ln m_S + ln D, b)."""
    ms = ln_m_s(u, c)
    s2 = slope_variance(p, beta)
    sin, cos = np.sin(theta), np.cos(theta)
    a = 4.0 * u * u
    k = 0.5 * (c + 1.0)
    base = ln_m_d(p, beta) + np.log((cos * cos + s2) / (1.0 + s2))
    b = base - k * np.log1p(a * sin * sin)
    narrow = ms + ln_d_smoothed(theta, u, p, beta)
    epd_core = logaddexp(narrow, base - k * np.log1p(a * (sin * sin + 2.0 * s2 / (1.0 + 2.0 * s2))))
    tail = logaddexp(narrow, b)
    return [ms, b, epd_core, tail]


def correction(theta, u, c, p, beta, v, interpolated):
    """sum_j alpha_j (t_j - interpolated_j): what the control variates add to the interpolated ln C
    at the points (stored angle v), given the terms interpolated there in the order of TERMS.
    A term of zero weight adds nothing (it may be infinite or NaN there)."""
    with np.errstate(all="ignore"):
        alpha = weights(u, p, beta, v)
        t = terms(theta, u, c, p, beta)
        total = np.zeros(np.shape(theta))
        for a, tj, ij in zip(alpha, t, interpolated):
            total = total + np.where(a != 0.0, a * (tj - ij), 0.0)
    return total
