"""The two-scale BRDF of docs/maths.md section 7 on numpy arrays, from the general tables of a preset.

The tests' second opinion (mitsuba/tests/test_bsdf.py): the Mitsuba BSDF (twoscale_mitsuba) and the C BRDF read
one material's tables; this model reads the default preset's general tables at any parameters.
Directions are in the local shading frame (z = normal), given as (n, 3) arrays; wavelengths and
lengths (b, sigma_s) in micrometres.

    rho(i, o) = F * [ A D(h) G2 / (4 cos_i cos_o) + (1 - A) G2 K(i, o) ]
    A = exp(-(4 pi sigma_s cos_d / lambda)^2),  K = (c-1) B^2 / (2 pi R) N(p)/beta^2 C(theta_h; B cos_d, c, p, beta)
"""
import math
from pathlib import Path

import numpy as np
from twoscale_tables import open_folder  # the reader package, pipeline/tables/python (`make pyenv` installs it)

LAMBDA_RANGE = (0.36, 0.83)  # micrometres: Mitsuba's spectral range


class TwoScaleError(ValueError):
    """A bad parameter, a missing table or a corrupt one: one line says which."""


def open_tables(path, names):
    """{name: Table} from a preset directory, checksums verified."""
    path = Path(path)
    if not path.is_dir():
        raise TwoScaleError(f"{path}: no such preset directory")
    try:
        return open_folder(path, names, "build it with `twoscale build --preset default`")
    except ValueError as e:
        raise TwoScaleError(str(e)) from None


def _dot(a, b):
    return np.sum(a * b, axis=-1)


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

    def eval_parts(self, wi, wo, lam, lobe=None):
        """(specular, diffraction) parts of rho / F at each (wi, wo, lambda), 0 below the horizon. `lobe`, when given,
        is C(theta_h; B cos theta_d) at every point, computed once where many points share it."""
        return self.eval_parts_at(wi, wo, [lam], [lobe])[0]

    def eval_parts_at(self, wi, wo, lams, lobes=None):
        """`eval_parts` at each wavelength of `lams` (each a scalar or one per point), `lobes` the matching `lobe`s:
        the wavelength-free factors (h, D, G2, R's sin theta_i) computed once for all of them."""
        wi, wo = np.atleast_2d(wi), np.atleast_2d(wo)
        lobes = lobes or [None] * len(lams)
        out = [(np.zeros(len(wi)), np.zeros(len(wi))) for _ in lams]
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        if not ok.any():
            return out
        wi, wo = wi[ok], wo[ok]
        h = wi + wo
        h /= np.linalg.norm(h, axis=1)[:, None]
        cos_i, cos_o, cos_h = wi[:, 2], wo[:, 2], h[:, 2]
        cos_d = np.clip(_dot(wi, h), 0.0, 1.0)
        g1i, g1o = self.g1(cos_i), self.g1(cos_o)
        # Height-correlated Smith: 1 / (1 + Lambda_i + Lambda_o), Lambda = 1/G1 - 1.
        with np.errstate(divide="ignore"):
            g2 = np.where((g1i > 0) & (g1o > 0), 1.0 / (1.0 / g1i + 1.0 / g1o - 1.0), 0.0)
        d, four_cos = self.ndf(cos_h), 4.0 * cos_i * cos_o
        sin_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
        for (spec, diff), lam, lobe in zip(out, lams, lobes):
            lam = np.broadcast_to(np.asarray(lam, dtype=np.float64), ok.shape)[ok]
            a = self.attenuation(cos_d, lam)
            spec[ok] = a * d * g2 / four_cos
            if self.diffracts:
                bb = self.b / lam
                r = self.t["kcorr_renorm"].lookup_arrays({"s": sin_i, "b_over_lambda": bb, "c": self.c}, ["r"])["r"]
                c = self.lobe_c(bb * cos_d, cos_h) if lobe is None else lobe[ok]
                k = (self.c - 1.0) * bb * bb / (2.0 * math.pi * r) * self.n_p / self.beta**2 * c
                diff[ok] = (1.0 - a) * g2 * k
        return out
