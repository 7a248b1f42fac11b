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


# -- docs/maths.md section 10: a plastic without diffraction, by brute force -----------------------------
def dielectric(cos_t, eta):
    """Unpolarised reflectance of a smooth dielectric of index eta, from the s and p amplitudes (Snell's law)."""
    cos_t = np.abs(cos_t)
    sin_t2 = (1.0 - cos_t * cos_t) / (eta * eta)
    cos_r = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    rs = (cos_t - eta * cos_r) / (cos_t + eta * cos_r)
    rp = (eta * cos_t - cos_r) / (eta * cos_t + cos_r)
    return 0.5 * (rs * rs + rp * rp)


def gauss_panels(lo, hi, panels, n):
    """Nodes and weights of n-point Gauss-Legendre on `panels` equal panels over [lo, hi]."""
    edges = np.linspace(lo, hi, panels + 1)
    gx, gw = np.polynomial.legendre.leggauss(n)
    a, b = edges[:-1, None], edges[1:, None]
    return (0.5 * (a + b) + 0.5 * (b - a) * gx).ravel(), (0.5 * (b - a) * gw).ravel()


class Plastic:
    """rho of docs/maths.md section 10 for a plastic without diffraction (energy single): F_eta D G2 / (4 cos_i cos_o)
    plus d_eff T(i) T(o) / (pi T_avg), with E_F(mu) = int F_eta rho cos theta_o do by a Gauss product over the half
    vector cut at the horizon (e_f), G1 from smith_lambda tabulated on 1,200 nodes in ln a (linear), E_F_avg by
    32-point Gauss-Legendre in mu. Nothing from the tables. About 5 ms per E_F, 2-3 s to set up."""

    def __init__(self, beta, p, ior, diffuse):
        self.beta, self.p, self.ior, self.diffuse = beta, p, ior, diffuse
        self.ln_a = np.linspace(math.log(1e-6), math.log(1e6), 1200)
        self.lam = np.array([smith_lambda(p, a) for a in np.exp(self.ln_a)])
        mx, mw = np.polynomial.legendre.leggauss(32)
        mus, mws = 0.5 * (mx + 1), 0.5 * mw
        self.e_avg = float(sum(2 * w * mu * self.e_f(mu) for mu, w in zip(mus, mws)))
        self.t_avg = 1.0 - self.e_avg

    def g1(self, cos_t):
        cos_t = np.clip(cos_t, 1e-12, 1.0)
        a = self.beta * np.sqrt(1.0 - cos_t * cos_t) / cos_t
        la = np.log(np.maximum(a, 1e-300))
        lam = np.where(la < self.ln_a[0], 0.0, np.interp(la, self.ln_a, self.lam))
        return 1.0 / (1.0 + lam)

    def interface(self, wi, wo):
        """F_eta D G2 / (4 cos_i cos_o) at arrays of directions [n, 3]."""
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        cos_h = h[..., 2]
        tan2 = (1.0 - cos_h * cos_h) / (cos_h * cos_h)
        d = norm_p(self.p) / self.beta**2 * np.exp(-((tan2 / self.beta**2) ** self.p)) / cos_h**4
        g1i, g1o = self.g1(wi[..., 2]), self.g1(wo[..., 2])
        g2 = 1.0 / (1.0 / g1i + 1.0 / g1o - 1.0)
        cos_d = np.clip(np.sum(wi * h, axis=-1), 0.0, 1.0)
        return dielectric(cos_d, self.ior) * d * g2 / (4.0 * wi[..., 2] * wo[..., 2])

    def e_f(self, mu):
        """E_F(mu) over the half vector h = (theta, phi), o = 2 (i.h) h - i, do = 4 (i.h) dh, i = (s, 0, mu). o is
        above the horizon where cos phi > kappa(theta) = -(mu / s) cot 2 theta: every phi up to theta_1 = atan2(mu, s)
        / 2, none beyond theta_2 = pi/2 - theta_1, phi in [0, acos kappa] between (at mu = 1, theta_1 = theta_2 =
        pi/4). Gauss-Legendre in x = ln tan theta, panels of about 0.2 x 8 nodes from x_0 = ln(1e-4 beta) (D is
        nothing below) to x_1 and from max(x_0, x_1) to x_2 (capped at ln 1e3), 32 nodes in phi over [0, pi] or
        [0, acos kappa] (twice: phi is symmetric). The cut is a panel edge, so the rule converges: within 3e-7 of
        one 8 times finer, at mu from 1e-6 to 1, over 7 plastics. 0 at mu <= 0."""
        mu = float(mu)
        if mu <= 0.0:
            return 0.0
        s = math.sqrt(max(1.0 - mu * mu, 0.0))
        i = np.array([s, 0.0, mu])
        th1 = 0.5 * math.atan2(mu, s)
        x0, x1, x2 = math.log(1e-4 * self.beta), math.log(math.tan(th1)), min(math.log(math.tan(0.5 * math.pi - th1)), math.log(1e3))
        segments = [(x0, x1, False)] + ([(max(x0, x1), x2, True)] if s > 0.0 else [])
        px, pw = np.polynomial.legendre.leggauss(32)
        total = 0.0
        for lo, hi, cut in segments:
            if hi <= lo:
                continue
            xs, xw = gauss_panels(lo, hi, math.ceil((hi - lo) / 0.2), 8)
            t = np.exp(xs)
            th = np.arctan(t)
            kappa = -(mu / s) / np.tan(2.0 * th) if cut else -1.0
            half = 0.5 * np.arccos(np.clip(kappa, -1.0, 1.0)) * np.ones_like(th)
            phi = half[:, None] * (px + 1.0)
            st, ct = np.sin(th)[:, None], np.cos(th)[:, None]
            h = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct), -1).reshape(-1, 3)
            w = (2.0 * xw[:, None] * half[:, None] * pw * st * (t / (1.0 + t * t))[:, None]).reshape(-1)
            ih = h @ i
            o = 2.0 * ih[:, None] * h - i
            keep = o[:, 2] > 0  # rounding at the cut (o_z > 0 implies i.h > 0)
            o = o[keep]
            total += float((self.interface(np.broadcast_to(i, o.shape), o) * o[:, 2] * 4.0 * ih[keep] * w[keep]).sum())
        return total

    def d_eff(self, lam):
        d = self.diffuse(lam)
        r = 1.0 - self.t_avg / self.ior**2
        return d * (1.0 - r) / (1.0 - d * r)

    def eval(self, wi, wo, lam):
        """(rho, its interface part) at one (wi, wo, lambda um)."""
        wi, wo = np.asarray(wi, float), np.asarray(wo, float)
        t_i, t_o = (max(1.0 - self.e_f(w[2]), 0.0) for w in (wi, wo))
        spec = float(self.interface(wi[None], wo[None])[0])
        return spec + self.d_eff(lam) * t_i * t_o / (math.pi * self.t_avg), spec


def henyey_greenstein(c, g):
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * c) ** 1.5)


class Subsurface(Plastic):
    """rho of docs/maths.md section 11 for a subsurface material without diffraction (energy single): Plastic's
    interface and T, then Jensen et al.'s single-scattering term with the refracted directions and the dipole's
    R_d (1 - alpha s_max); s_max = max over the refracted incidences of s(mu') by scipy's dblquad (nothing from
    the tables or the Rust rule), on 9 points in mu'."""

    def __init__(self, beta, p, ior, albedo, g):
        super().__init__(beta, p, ior, albedo)
        self.g = g
        mu_c = math.sqrt(1.0 - 1.0 / ior**2)
        self.s_max = max(self.single_share(mu) for mu in np.linspace(mu_c, 1.0, 9))

    def single_share(self, mu):
        from scipy.integrate import dblquad
        s_i = math.sqrt(max(1.0 - mu * mu, 0.0))

        def f(phi, mo):
            c = -s_i * math.sqrt(1.0 - mo * mo) * math.cos(phi) - mu * mo
            return 2.0 * henyey_greenstein(c, self.g) * mo / (mu + mo)

        return dblquad(f, 0.0, 1.0, 0.0, math.pi, epsabs=1e-11, epsrel=1e-9)[0]

    def eval(self, wi, wo, lam):
        wi, wo = np.asarray(wi, float), np.asarray(wo, float)
        t_i, t_o = (max(1.0 - self.e_f(w[2]), 0.0) for w in (wi, wo))
        spec = float(self.interface(wi[None], wo[None])[0])
        a, eta, g = self.diffuse(lam), self.ior, self.g
        alpha = a / (a + (1.0 - a) * (1.0 - g))
        r = 1.0 - self.t_avg / eta**2
        s3 = math.sqrt(3.0 * (1.0 - a))
        r_d = 0.5 * a * (1.0 + math.exp(-4.0 / 3.0 * (1.0 + r) / (1.0 - r) * s3)) * math.exp(-s3)
        multi = r_d * (1.0 - alpha * self.s_max) * t_i * t_o / (math.pi * self.t_avg)
        mi, mo = (math.sqrt(1.0 - (1.0 - w[2] ** 2) / eta**2) for w in (wi, wo))
        c = -(wi[0] * wo[0] + wi[1] * wo[1]) / eta**2 - mi * mo
        single = alpha * t_i * t_o * henyey_greenstein(c, g) / (eta**2 * (mi + mo))
        return spec + multi + single, spec
