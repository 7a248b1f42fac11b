"""The general tables of a preset folder (`tables-out/default`, or a bundle of it) read in Dr.Jit at parameters
that vary from lane to lane: what the BSDF's general mode evaluates and samples with (docs/runtimes.md
"General mode").

Each table is one flat buffer per value, read by `dr.gather`: multilinear interpolation in the encoded
coordinates (2^N reads per value; docs/file_contract.md), 4-point Lagrange along each axis for the cubic
tables (4^N reads). The weights are Dr.Jit arithmetic on the coordinates, so gradients flow to every
parameter; a coordinate outside an axis is clamped to it. Dr.Jit's `Texture` stops at three dimensions and
zh_lobe has five; its four control variates share the value's cell, so one set of corner weights serves all
five datasets.
"""
import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
from twoscale_tables import open_folder

from .lookup import LAMBDA_RANGE, TwoScaleError, bounded_log_tan, buffer, encode, expm1, gather, lobe_angle, log1p, opaque, quantile_density

LN_PI = math.log(math.pi)
FRAC_PI_2 = math.pi / 2
# zh_lobe's control variates, in the order the file contract fixes.
CV_TERMS = ("ln_m_s", "b", "epd_core", "tail")


def is_preset(folder):
    """Whether `folder` (or the one a bundle unpacked to) holds a preset's tables: general tables, no material section."""
    return (Path(folder) / "epd_norm.manifest.json").exists()


def open_preset(folder, names, bundle=None):
    """{table: Table} of a preset folder, or of the folder the bundle `bundle` unpacked to, every checksum verified before use."""
    origin = f"{bundle}: " if bundle is not None else ""
    try:
        tables = open_folder(folder, names, "build it with `twoscale build --preset default`")
    except ValueError as e:  # names the file (and the dataset of a checksum mismatch)
        raise TwoScaleError(f"{origin}{e}") from None
    for name, t in tables.items():
        if t.manifest.get("material") is not None:
            raise TwoScaleError(f"{origin}{Path(folder) / name}.h5: a per-material table, not a preset's")
    return tables


# -- axes and interpolation -----------------------------------------------------------------------
class Axis:
    """An axis uniform in its encoding: a coordinate's position in node units, clamped to [0, n - 1]."""

    def __init__(self, table, name, kind):
        names = [a["name"] for a in table.manifest["axes"]]
        if name not in names:
            raise TwoScaleError(f"{table.manifest['table']}: no axis {name} (not a preset table of this version)")
        k = names.index(name)
        a = table.manifest["axes"][k]
        if a["encoding"]["kind"] != kind or not a.get("uniform"):
            raise TwoScaleError(f"{table.manifest['table']}: axis {name} is not uniform in the encoding {kind} "
                                "(docs/file_contract.md): not a preset table of this version")
        e = table.encoded[k]
        self.n, self.lo, self.hi = a["size"], float(table.axes[k].min()), float(table.axes[k].max())
        self.enc = {key: (v if key == "kind" else opaque(v)) for key, v in a["encoding"].items()}
        self.e0, self.inv_step = opaque(e[0]), opaque((self.n - 1) / float(e[-1] - e[0]))

    def pos_e(self, e):
        return dr.clip((e - self.e0) * self.inv_step, 0.0, self.n - 1.0)

    def pos(self, x):
        return self.pos_e(encode(self.enc, x))


def _cell(pos, n):
    """(node i, weight t) of a position in node units: i <= n - 2, t in [0, 1]."""
    i = dr.minimum(mi.UInt32(dr.floor(pos)), n - 2)
    return i, pos - mi.Float(i)


def _strides(shape):
    out, s = [], 1
    for n in reversed(shape):
        out.insert(0, s)
        s *= n
    return out


class Grid:
    """A table's values on its grid, read multilinearly (or cubically) at positions in node units."""

    def __init__(self, table, names):
        self.shape = [a["size"] for a in table.manifest["axes"]]
        self.strides = _strides(self.shape)
        self.bufs = [buffer(table.values[n]) for n in names]
        # Values stored as ln without control variates (docs/file_contract.md "Value encodings"): exp after
        # interpolating. zh_lobe's c_lobe, with control variates, is decoded by its caller.
        ln = {e["value"] for e in table.manifest.get("value_encoding", []) if e["kind"] == "ln" and not e.get("control_variates")}
        self.exp = [n in ln for n in names]

    def linear(self, positions):
        """The values at positions (one per axis, node units): 2^N gathers per value."""
        cells = [_cell(p, n) for p, n in zip(positions, self.shape)]
        base = mi.UInt32(0)
        for (i, _), s in zip(cells, self.strides):
            base = base + i * s
        out = [0.0] * len(self.bufs)
        dims = len(cells)
        for corner in range(1 << dims):
            w, off = 1.0, 0
            for k, ((_, t), s) in enumerate(zip(cells, self.strides)):
                if corner >> (dims - 1 - k) & 1:
                    w, off = w * t, off + s
                else:
                    w = w * (1.0 - t)
            for j, buf in enumerate(self.bufs):
                out[j] = out[j] + w * gather(buf, base + off)
        return [dr.exp(x) if e else x for x, e in zip(out, self.exp)]

    def cubic(self, positions):
        """4-point Lagrange along each axis (docs/file_contract.md "Interpolation"): 4^N gathers per value."""
        stencils = []
        for p, n in zip(positions, self.shape):
            i, t = _cell(p, n)
            s = dr.minimum(dr.maximum(i, 1), n - 3) - 1
            tau = t + mi.Float(i) - mi.Float(s) - 1.0
            w = [-tau * (tau - 1.0) * (tau - 2.0) / 6.0, (tau + 1.0) * (tau - 1.0) * (tau - 2.0) / 2.0,
                 -(tau + 1.0) * tau * (tau - 2.0) / 2.0, (tau + 1.0) * tau * (tau - 1.0) / 6.0]
            stencils.append((s, w))
        base = mi.UInt32(0)
        for (s, _), st in zip(stencils, self.strides):
            base = base + s * st
        out = [0.0] * len(self.bufs)
        dims = len(stencils)
        for corner in range(4 ** dims):
            w, off = 1.0, 0
            for k, ((_, wk), st) in enumerate(zip(stencils, self.strides)):
                d = corner // 4 ** (dims - 1 - k) % 4
                w, off = w * wk[d], off + d * st
            for j, buf in enumerate(self.bufs):
                out[j] = out[j] + w * gather(buf, base + off)
        return out


# -- zh_lobe's control variates (docs/maths.md section 4b; twoscale_tables/_lobe.py in numpy) -------
def _smoothstep(y, lo, hi):
    x = dr.clip((y - lo) / (hi - lo), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _logaddexp(a, b):
    m = dr.maximum(a, b)
    return m + dr.log(dr.exp(a - m) + dr.exp(b - m))


def _ln_m_s(u, c):
    """ln m_S = ln(pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1))); below 4u^2 = 1e-4 its series
    ln pi - (c + 1) u^2 (error O(u^4), and float32 has no digits for the difference there)."""
    a = 4.0 * u * u
    k = 0.5 * (c - 1.0)
    small = a < 1e-4
    a_safe = dr.select(small, 1.0, a)
    full = dr.log(math.pi * -expm1(-k * log1p(a_safe)) / (a_safe * k))
    return dr.select(small, LN_PI - 0.5 * (k + 1.0) * a, full)


def lobe_terms(theta, u, c, p, beta, v):
    """(alpha_j, q_j) of CV_TERMS at the query point (stored angle v)."""
    ms = _ln_m_s(u, c)
    lg1, lg2 = dr.lgamma(1.0 / p), dr.lgamma(2.0 / p)
    s2 = 0.5 * beta * beta * dr.exp(lg2 - lg1)
    ln_m_d = 2.0 * dr.log(beta) + LN_PI + lg1 - dr.log(p)
    sin, cos = dr.sincos(theta)
    a = 4.0 * u * u
    k = 0.5 * (c + 1.0)
    base = ln_m_d + dr.log((cos * cos + s2) / (1.0 + s2))
    b = base - k * log1p(a * sin * sin)
    e = dr.minimum(dr.sqrt(theta * theta + 0.25 / (1.0 + a)), FRAC_PI_2)
    sin_e, cos_e = dr.sincos(e)
    cos_e = dr.maximum(cos_e, 1e-30)
    narrow = ms - dr.power(sin_e / (cos_e * beta), 2.0 * p) - 4.0 * dr.log(cos_e)
    epd_core = _logaddexp(narrow, base - k * log1p(a * (sin * sin + 2.0 * s2 / (1.0 + 2.0 * s2))))
    tail = _logaddexp(narrow, b)
    ws2 = 1.0 / (1.0 + a)
    wd2 = dr.square(beta / (2.0 * p))
    lam = dr.square(wd2 / (ws2 + wd2))
    mu = lam * lam * _smoothstep(p, 0.3, 0.5)
    peak = -2.0 / p + 2.0 * log1p(beta * beta * dr.power(2.0 / p, 1.0 / p))
    w = _smoothstep(v, 0.2, 0.5) * (1.0 - _smoothstep(peak, -4.0, -1.0))
    return [(1.0 - w) * (lam - mu), (1.0 - w) * (1.0 - lam), (1.0 - w) * mu, w], [ms, b, epd_core, tail]


# -- the tables ------------------------------------------------------------------------------------
class GeneralTables:
    """Lookups of the default preset's general tables at per-lane parameters. `lobe`: "exact" reads zh_lobe,
    "fit" zh_convolution's cos lobe; `energy`: also epd_albedo and epd_albedo_avg."""

    def __init__(self, folder, lobe, energy, bundle=None):
        names = ["epd_g1", "epd_norm", "epd_quantile", "kcorr_renorm", "zh_convolution"]
        names += ["zh_lobe"] if lobe == "exact" else []
        names += ["epd_albedo", "epd_albedo_avg"] if energy else []
        t = open_preset(folder, names, bundle)
        g1 = t["epd_g1"]
        self.g1_p, self.g1_a, self.g1 = Axis(g1, "p", "reciprocal"), Axis(g1, "a", "bounded_log"), Grid(g1, ["g1"])
        self.norm_p, self.norm = Axis(t["epd_norm"], "p", "reciprocal"), Grid(t["epd_norm"], ["n"])
        q = t["epd_quantile"]
        self.q_p, self.q_xi, self.q = Axis(q, "p", "log"), Axis(q, "xi", "asin_sqrt"), Grid(q, ["theta"])
        self.q_buf, self.q_n = self.q.bufs[0], self.q.shape[1]
        kc = t["kcorr_renorm"]
        self.r_axes = (Axis(kc, "s", "log_gap"), Axis(kc, "b_over_lambda", "log_plus_log_log1p_sq"), Axis(kc, "c", "shifted_log"))
        self.r = Grid(kc, ["r"])
        zc = t["zh_convolution"]
        self.fit_axes = (Axis(zc, "u", "shifted_log"), Axis(zc, "c", "linear"), Axis(zc, "p", "log"), Axis(zc, "beta", "log"))
        self.fit_cos, self.fit_g = Grid(zc, ["s_cos", "g_cos"]), Grid(zc, ["g"])
        self.lobe = None
        if lobe == "exact":
            self._open_lobe(t["zh_lobe"])
        if energy:
            ea, eavg = t["epd_albedo"], t["epd_albedo_avg"]
            for table in (ea, eavg):
                if table.manifest.get("interpolation") != "cubic":
                    raise TwoScaleError(f"{table.manifest['table']}: not a cubic table (docs/file_contract.md)")
            self.alb_axes = (Axis(ea, "p", "reciprocal"), Axis(ea, "beta", "log"), Axis(ea, "theta_i", "bounded_log_tan"))
            self.alb, self.alb_avg = Grid(ea, ["e"]), Grid(eavg, ["e_avg"])
            self.alb_avg_axes = (Axis(eavg, "p", "reciprocal"), Axis(eavg, "beta", "log"))
        self.domain = self._domain(t)

    def _open_lobe(self, zl):
        derived = zl.manifest.get("derived_axes", [])
        if len(derived) != 1 or derived[0]["kind"] != "anchored_lobe_angle" or derived[0]["inputs"] != ["u", "p", "beta"]:
            raise TwoScaleError("zh_lobe: its angle is not an anchored_lobe_angle of (u, p, beta): not a preset table of this version")
        enc = zl.manifest.get("value_encoding", [])
        cvs = [cv["term"] for cv in enc[0].get("control_variates", [])] if len(enc) == 1 else []
        if len(enc) != 1 or enc[0]["value"] != "c_lobe" or enc[0]["kind"] != "ln" or tuple(cvs) != CV_TERMS:
            raise TwoScaleError("zh_lobe: its value encoding is not ln with the control variates " + ", ".join(CV_TERMS))
        d = derived[0]
        self.angle = {"k": opaque(d["k"]), "v_anchor": float(d["v_anchor"]), "theta_cap": opaque(d["theta_cap"])}
        self.lobe_axes = (Axis(zl, "u", "log1p_sq"), Axis(zl, "c", "linear"), Axis(zl, "p", "shifted_log"),
                          Axis(zl, "beta", "log"), Axis(zl, "v_theta", "linear"))
        self.lobe = Grid(zl, ["c_lobe"] + [cv["values"] for cv in enc[0]["control_variates"]])

    def _domain(self, t):
        """{parameter: (lo, hi)} over which every table reads inside its axes at every wavelength Mitsuba
        samples: beta and c from the zh tables, p from epd_g1 (and the zh tables where sigma_s > 0), b from
        kcorr_renorm's B and the zh tables' u = B cos theta_d."""
        zc = self.fit_axes
        b_lo = self.r_axes[1].lo * LAMBDA_RANGE[1]
        b_hi = min(self.r_axes[1].hi, zc[0].hi) * LAMBDA_RANGE[0]
        return {"beta": (zc[3].lo, zc[3].hi), "p": (self.g1_p.lo, self.g1_p.hi), "p_diffraction": (zc[2].lo, zc[2].hi),
                "sigma_s": (0.0, math.inf), "b": (b_lo, b_hi), "c": (zc[1].lo, zc[1].hi)}

    # -- section 7's tables -------------------------------------------------------------------------
    def n_p(self, p):
        return self.norm.linear([self.norm_p.pos(p)])[0]

    def g1_at(self, p, beta, sin_t, cos_t):
        """G1(p, a = beta tan theta), the a axis's bounded_log written in (sin, cos)."""
        e = bounded_log_tan(self.g1_a.enc, beta * sin_t, cos_t)
        return self.g1.linear([self.g1_p.pos(p), self.g1_a.pos_e(e)])[0]

    def r_at(self, sin_t, bb, c):
        """R(s = sin theta, B, c) of kcorr_renorm."""
        s, b_axis, c_axis = self.r_axes
        return self.r.linear([s.pos(sin_t), b_axis.pos(bb), c_axis.pos(c)])[0]

    def lobe_exact(self, u, c, p, beta, theta_h):
        """C(theta_h; u, c, p, beta) of zh_lobe: ln C interpolated, plus its control variates."""
        d = self.angle
        edge_d = dr.atan(beta * dr.exp(dr.log(d["k"]) / (2.0 * p)))
        v = lobe_angle(theta_h, u, edge_d, d["theta_cap"], d["v_anchor"])
        ax = self.lobe_axes
        s, *cv = self.lobe.linear([ax[0].pos(u), ax[1].pos(c), ax[2].pos(p), ax[3].pos(beta), ax[4].pos(v)])
        alpha, q = lobe_terms(theta_h, u, c, p, beta, v)
        ln_c = s
        for a_j, q_j, i_j in zip(alpha, q, cv):
            ln_c = ln_c + dr.select(a_j != 0.0, a_j * (q_j - i_j), 0.0)
        return dr.exp(ln_c)

    def _fit_pos(self, u, c, p, beta):
        return [ax.pos(x) for ax, x in zip(self.fit_axes, (u, c, p, beta))]

    def fitted_cos(self, u, c, p, beta):
        """(s_cos, g_cos) of zh_convolution: the cos lobe s_cos (1 + 4 g_cos^2 sin^2)^(-(c+1)/2) cos^2."""
        return self.fit_cos.linear(self._fit_pos(u, c, p, beta))

    # -- sampling the diffraction part: the plain fitted lobe, inverted in closed form -------------------
    def _lobe_shape(self, u, c, p, beta):
        """(a, k): the sampled half-vector density is (1 + a sin^2 theta_h)^(-(k+1)) cos theta_h / (pi Z) in solid
        angle, a = 4 g^2 with g of zh_convolution's plain lobe at u, k = (c - 1)/2, Z = (1 - (1 + a)^-k) / (a k)."""
        g = self.fit_g.linear(self._fit_pos(u, c, p, beta))[0]
        return dr.maximum(4.0 * g * g, 1e-12), 0.5 * (c - 1.0)

    def sample_lobe(self, u, c, p, beta, xi):
        """theta_h with x = sin^2 theta_h = ((1 - xi (1 - (1 + a)^-k))^(-1/k) - 1) / a, the inverse of the CDF in x,
        (1 - (1 + a x)^-k) / (1 - (1 + a)^-k) (written with log1p and expm1: k and a x can be small)."""
        a, k = self._lobe_shape(u, c, p, beta)
        z = -expm1(-k * log1p(a))
        x = dr.clip(expm1(-log1p(-xi * z) / k) / a, 0.0, 1.0)
        return dr.atan2(dr.sqrt(x), dr.sqrt(1.0 - x))

    def lobe_density(self, u, c, p, beta, sin_h, cos_h):
        """The density in theta_h of sample_lobe: 2 sin cos (1 + a sin^2)^-(k+1) / Z."""
        a, k = self._lobe_shape(u, c, p, beta)
        inv_z = a * k / -expm1(-k * log1p(a))
        return 2.0 * sin_h * cos_h * dr.exp(-(k + 1.0) * log1p(a * sin_h * sin_h)) * inv_z

    def albedo(self, p, beta, sin_t, cos_t):
        """E(mu) of epd_albedo (cubic), theta_i's bounded_log_tan written in (sin, cos)."""
        ax = self.alb_axes
        e = bounded_log_tan(ax[2].enc, sin_t, cos_t)
        return self.alb.cubic([ax[0].pos(p), ax[1].pos(beta), ax[2].pos_e(e)])[0]

    def albedo_avg(self, p, beta):
        ax = self.alb_avg_axes
        return self.alb_avg.cubic([ax[0].pos(p), ax[1].pos(beta)])[0]

    # -- sampling the EPD: epd_quantile, theta_1 at beta = 1, tan theta_m = beta tan theta_1 ----------------
    def sample_epd(self, p, beta, xi):
        """theta_m of the EPD at (beta, p) for the uniform xi: the bilinear read of theta_1 = the quantile of
        D cos theta at beta = 1, then tan theta_m = beta tan theta_1 (the slope density is radial)."""
        theta_1 = self.q.linear([self.q_p.pos(p), self.q_xi.pos(xi)])[0]
        sin_1, cos_1 = dr.sincos(theta_1)
        return dr.atan2(beta * sin_1, dr.maximum(cos_1, 0.0))

    def epd_density(self, p, beta, sin_h, cos_h):
        """The density in theta_m that sample_epd realises: the quantile row interpolated in p (weight t between
        rows i and i + 1), its density in theta_1 (docs/runtimes.md), times d theta_1 / d theta_m =
        beta / (beta^2 cos^2 theta_m + sin^2 theta_m)."""
        i, t = _cell(self.q_p.pos(p), self.q.shape[0])
        theta_1 = dr.atan2(sin_h, beta * cos_h)
        row = i * self.q_n
        dens = quantile_density(self.q_buf, row, self.q_n, theta_1, (row + self.q_n, t))
        return dens * beta / (dr.square(beta * cos_h) + dr.square(sin_h))
