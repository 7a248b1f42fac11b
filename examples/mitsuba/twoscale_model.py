"""The two-scale BRDF of docs/maths.md section 7 on numpy arrays, from twoscale tables.

No Mitsuba here: `twoscale_bsdf.py` wraps this for the renderer, and the tests
call it directly. Directions are in the local shading frame (z = normal), given
as (n, 3) arrays; wavelengths in micrometres; lengths (b, sigma_s) in micrometres.

    rho(i, o) = F * [ A D(h) G2 / (4 cos_i cos_o) + (1 - A) G2 K(i, o) ]
    A = exp(-(4 pi sigma_s cos_d / lambda)^2),  K = (c-1) B^2 / (2 pi R) N(p)/beta^2 C(theta_h; B cos_d, c, p, beta)

Sampling (one mixture, pdf exact): with probability 1 - w_d the specular part,
m ~ D(m) cos theta_m (tan^2 theta_m = beta^2 Q^-1(1/p, xi)^(1/p)) and o = reflect(i, m);
with probability w_d the diffraction part, h with projected-disk density
proportional to (1 + a^2 |h_xy|^2)^(-(c+1)/2), a = 2 g (g of zh_convolution's plain fit at
u = B cos theta_i, the lobe's width at its peak; a >= A_MIN), and o = reflect(i, h).
w_d = 0 without diffraction (sigma_s = 0), else clip(1 - A(cos_d = cos_i), W_MIN, 1 - W_MIN):
the diffraction part's share of the energy at normal-incidence-like geometry, never starving
either strategy. Both use the hero wavelength (the first of a spectral sample).
"""
import math
import tarfile
import tempfile
from pathlib import Path

import numpy as np
from scipy.special import gammainccinv
from twoscale_tables import Table  # the reader package, pipeline/contract/python (`make pyenv` installs it)

W_MIN = 0.1  # smallest share of either sampling strategy
A_MIN = 0.25  # smallest 2 g of the diffraction proposal (broad lobes sample the disk almost uniformly)
LAMBDA_RANGE = (0.36, 0.83)  # micrometres: Mitsuba's spectral range


class TwoScaleError(ValueError):
    """A bad parameter, a missing table or a corrupt one: one line says which."""


def open_tables(path, names):
    """{name: Table} from a preset directory or a bundle (.tar.gz), checksums verified."""
    path = Path(path)
    if path.is_file() and path.name.endswith(".tar.gz"):
        # The tables are read into memory: the unpacked bundle is not needed afterwards.
        with tempfile.TemporaryDirectory(prefix="twoscale-bundle-") as tmp:
            try:
                with tarfile.open(path) as tar:
                    tar.extractall(tmp, filter="data")
            except (OSError, tarfile.TarError) as e:
                raise TwoScaleError(f"{path}: not a readable bundle ({e})") from None
            dirs = [d for d in Path(tmp).iterdir() if d.is_dir()]
            return _open_dir(dirs[0] if len(dirs) == 1 else Path(tmp), names, f"{path}: ")
    if not path.is_dir():
        raise TwoScaleError(f"{path}: no such preset directory or bundle")
    return _open_dir(path, names, "")


def _open_dir(path, names, origin):
    tables = {}
    for name in names:
        h5 = path / f"{name}.h5"
        if not h5.exists():
            raise TwoScaleError(f"{origin}{path}: table {name} is missing (build it with `twoscale build --table {name}`)")
        try:
            tables[name] = Table.open(h5)
        except ValueError as e:  # the reader's checksum message names the file and the dataset
            raise TwoScaleError(f"{origin}{e}") from None
        except (OSError, KeyError) as e:
            raise TwoScaleError(f"{origin}{h5}: unreadable table ({e})") from None
    return tables


def fresnel_conductor(cos_t, eta, k):
    """Unpolarised Fresnel reflectance of a conductor with index eta + i k (real arithmetic)."""
    c2 = cos_t * cos_t
    s2 = 1.0 - c2
    t1 = eta * eta - k * k - s2
    a2b2 = np.sqrt(t1 * t1 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t1), 0.0))
    t2 = 2.0 * cos_t * a
    rs = (a2b2 + c2 - t2) / (a2b2 + c2 + t2)
    t3 = a2b2 * c2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    return 0.5 * (rs + rp)


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _reflect(i, m):
    return 2.0 * _dot(i, m)[:, None] * m - i


class TwoScaleModel:
    """The BRDF of one material. lobe = "fit" (zh_convolution's fitted lobe; fit_variant "cos" or
    "plain") or "exact" (zh_lobe); sigma_s = 0 leaves the EPD microfacet lobe alone."""

    def __init__(self, tables, beta, p, sigma_s=0.0, b=1.0, c=2.0, lobe="fit", fit_variant="cos"):
        self.beta, self.p, self.sigma_s, self.b, self.c = float(beta), float(p), float(sigma_s), float(b), float(c)
        self.lobe, self.fit_variant = lobe, fit_variant
        if lobe not in ("fit", "exact"):
            raise TwoScaleError(f'lobe = {lobe!r}: expected "fit" or "exact"')
        if fit_variant not in ("cos", "plain"):
            raise TwoScaleError(f'fit_variant = {fit_variant!r}: expected "cos" or "plain"')
        self.diffracts = self.sigma_s > 0.0
        if not self.sigma_s >= 0.0:
            raise TwoScaleError(f"sigma_s = {sigma_s}: must be >= 0")
        names = ["epd_g1", "epd_norm"]
        if self.diffracts:
            names += ["kcorr_renorm", "zh_convolution"] + (["zh_lobe"] if lobe == "exact" else [])
        self.t = tables if isinstance(tables, dict) else open_tables(tables, names)
        missing = [n for n in names if n not in self.t]
        if missing:
            raise TwoScaleError(f"table {missing[0]} is missing")
        # Parameters must lie inside every table they index, at every wavelength Mitsuba samples.
        self._check("p", self.p, self.t["epd_g1"], "p")
        if not self.beta > 0.0:
            raise TwoScaleError(f"beta = {beta}: must be > 0")
        if self.diffracts:
            zh = self.t["zh_convolution"]
            for name, v in (("p", self.p), ("beta", self.beta), ("c", self.c)):
                self._check(name, v, zh, name)
            for lam in LAMBDA_RANGE:
                self._check("b / lambda", self.b / lam, self.t["kcorr_renorm"], "b_over_lambda")
                self._check("u = b / lambda", self.b / lam, zh, "u")
        self.n_p = float(self.t["epd_norm"].lookup({"p": self.p})["n"])

    @staticmethod
    def _check(what, v, table, axis):
        names = [a["name"] for a in table.manifest["axes"]]
        nodes = table.axes[names.index(axis)]
        if not (nodes.min() <= v <= nodes.max()):
            raise TwoScaleError(f"{what} = {v:g} is outside the tables' domain [{nodes.min():g}, {nodes.max():g}]")

    # -- the pieces of docs/maths.md section 7 -------------------------------------------------
    def ndf(self, cos_h):
        """D(h) = N(p)/beta^2 exp(-(tan^2 theta_h / beta^2)^p) / cos^4 theta_h."""
        c2 = cos_h * cos_h
        tan2 = np.maximum(1.0 - c2, 0.0) / c2
        return self.n_p / self.beta**2 * np.exp(-np.power(tan2 / self.beta**2, self.p)) / (c2 * c2)

    def g1(self, cos_t):
        tan_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0)) / cos_t
        return self.t["epd_g1"].lookup_arrays({"p": self.p, "a": self.beta * tan_t}, ["g1"])["g1"]

    def attenuation(self, cos_d, lam):
        """A = exp(-(4 pi sigma_s cos_d / lambda)^2)."""
        return np.exp(-((4.0 * math.pi * self.sigma_s * cos_d / lam) ** 2))

    def lobe_c(self, u, cos_h):
        """C(theta_h; u, c, p, beta) of docs/maths.md section 4 (no N(p)/beta^2, no PSD normalisation)."""
        cos_h = np.clip(cos_h, 0.0, 1.0)
        if self.lobe == "exact":
            pt = {"u": u, "c": self.c, "p": self.p, "beta": self.beta, "theta_h": np.arccos(cos_h)}
            return self.t["zh_lobe"].lookup_arrays(pt, ["c_lobe"])["c_lobe"]
        names = ["s_cos", "g_cos"] if self.fit_variant == "cos" else ["s", "g"]
        fit = self.t["zh_convolution"].lookup_arrays({"u": u, "c": self.c, "p": self.p, "beta": self.beta}, names)
        sin2 = 1.0 - cos_h * cos_h
        if self.fit_variant == "cos":
            return fit["s_cos"] * (1.0 + 4.0 * fit["g_cos"] ** 2 * sin2) ** (-(self.c + 1) / 2) * cos_h * cos_h
        return fit["s"] * (1.0 + 4.0 * fit["g"] ** 2 * sin2) ** (-(self.c + 1) / 2)

    def eval_parts(self, wi, wo, lam):
        """(specular, diffraction) parts of rho / F at each (wi, wo, lambda), 0 below the horizon."""
        wi, wo = np.atleast_2d(wi), np.atleast_2d(wo)
        lam = np.broadcast_to(np.asarray(lam, dtype=np.float64), wi.shape[:1])
        spec, diff = np.zeros(len(wi)), np.zeros(len(wi))
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        if not ok.any():
            return spec, diff
        wi, wo, lam = wi[ok], wo[ok], lam[ok]
        h = wi + wo
        h /= np.linalg.norm(h, axis=1)[:, None]
        cos_i, cos_o, cos_h = wi[:, 2], wo[:, 2], h[:, 2]
        cos_d = np.clip(_dot(wi, h), 0.0, 1.0)
        g1i, g1o = self.g1(cos_i), self.g1(cos_o)
        # Height-correlated Smith: 1 / (1 + Lambda_i + Lambda_o), Lambda = 1/G1 - 1.
        with np.errstate(divide="ignore"):
            g2 = np.where((g1i > 0) & (g1o > 0), 1.0 / (1.0 / g1i + 1.0 / g1o - 1.0), 0.0)
        a = self.attenuation(cos_d, lam)
        spec[ok] = a * self.ndf(cos_h) * g2 / (4.0 * cos_i * cos_o)
        if self.diffracts:
            bb = self.b / lam
            sin_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
            r = self.t["kcorr_renorm"].lookup_arrays({"s": sin_i, "b_over_lambda": bb, "c": self.c}, ["r"])["r"]
            k = (self.c - 1.0) * bb * bb / (2.0 * math.pi * r) * self.n_p / self.beta**2 * self.lobe_c(bb * cos_d, cos_h)
            diff[ok] = (1.0 - a) * g2 * k
        return spec, diff

    def eval(self, wi, wo, lam, eta=None, k=None):
        """rho(i, o) (without the cosine); F = 1 when eta is None (white furnace)."""
        spec, diff = self.eval_parts(wi, wo, lam)
        if eta is None:
            return spec + diff
        wi, wo = np.atleast_2d(wi), np.atleast_2d(wo)
        h = wi + wo
        h /= np.maximum(np.linalg.norm(h, axis=1), 1e-300)[:, None]
        return fresnel_conductor(np.clip(_dot(wi, h), 0.0, 1.0), eta, k) * (spec + diff)

    # -- sampling ---------------------------------------------------------------
    def _weights_and_width(self, cos_i, lam):
        """w_d (probability of the diffraction strategy) and the proposal's a = 2 g per lane."""
        if not self.diffracts:
            return np.zeros_like(cos_i), np.ones_like(cos_i)
        w_d = np.clip(1.0 - self.attenuation(cos_i, lam), W_MIN, 1.0 - W_MIN)
        # One lookup per distinct u0 (a whole chi-square test, or a camera ray batch, shares wi and lambda).
        u0, inverse = np.unique(self.b / lam * cos_i, return_inverse=True)
        g = self.t["zh_convolution"].lookup_arrays({"u": u0, "c": self.c, "p": self.p, "beta": self.beta}, ["g"])["g"]
        return w_d, np.maximum(2.0 * g, A_MIN)[inverse.ravel()]

    def _disk_mass(self, a):
        """K = 1 - (1 + a^2)^((1-c)/2): the proposal's mass inside the unit disk (times a^2 (c-1) / 2 pi)."""
        return -np.expm1((1.0 - self.c) / 2.0 * np.log1p(a * a))

    def pdf(self, wi, wo, lam):
        """Solid-angle density of `sample` at wo (0 below the horizon)."""
        wi, wo = np.atleast_2d(wi), np.atleast_2d(wo)
        lam = np.broadcast_to(np.asarray(lam, dtype=np.float64), wi.shape[:1])
        out = np.zeros(len(wi))
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        if not ok.any():
            return out
        wi, wo, lam = wi[ok], wo[ok], lam[ok]
        h = wi + wo
        h /= np.linalg.norm(h, axis=1)[:, None]
        cos_h, i_h = h[:, 2], np.maximum(_dot(wi, h), 1e-300)
        w_d, a = self._weights_and_width(wi[:, 2], lam)
        # Specular: D(h) cos theta_h / (4 i.h).
        pdf = (1.0 - w_d) * self.ndf(cos_h) * cos_h / (4.0 * i_h)
        if self.diffracts:
            # Diffraction: density on the disk of h_xy, (c-1) a^2 / (2 pi K) (1 + a^2 r^2)^(-(c+1)/2), times cos theta_h.
            r2 = np.maximum(1.0 - cos_h * cos_h, 0.0)
            q = (self.c - 1.0) * a * a / (2.0 * math.pi * self._disk_mass(a)) * (1.0 + a * a * r2) ** (-(self.c + 1) / 2)
            pdf = pdf + w_d * q * cos_h / (4.0 * i_h)
        out[ok] = pdf
        return out

    def sample(self, wi, xi0, xi1, xi2, lam):
        """Outgoing directions for uniform (xi0, xi1, xi2); o.z <= 0 marks a lost sample."""
        wi = np.atleast_2d(wi)
        n = len(wi)
        lam = np.broadcast_to(np.asarray(lam, dtype=np.float64), (n,))
        w_d, a = self._weights_and_width(np.maximum(wi[:, 2], 1e-300), lam)
        phi = 2.0 * math.pi * xi2
        # Specular: tan^2 theta_m = beta^2 Q^-1(1/p, xi)^(1/p).
        tan2 = self.beta**2 * np.power(gammainccinv(1.0 / self.p, np.clip(xi1, 0.0, 1.0)), 1.0 / self.p)
        sin2 = np.where(np.isinf(tan2), 1.0, tan2 / (1.0 + tan2))
        # Diffraction: invert the disk CDF (1 - (1 + a^2 r^2)^((1-c)/2)) / K.
        if self.diffracts:
            r2 = np.expm1(2.0 / (1.0 - self.c) * np.log1p(-xi1 * self._disk_mass(a))) / (a * a)
            sin2 = np.where(xi0 < w_d, np.clip(r2, 0.0, 1.0), sin2)
        sin_t, cos_t = np.sqrt(sin2), np.sqrt(1.0 - sin2)
        m = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)
        return _reflect(wi, m)
