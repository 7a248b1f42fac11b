"""The BSDF's table reads: the folder a bundle unpacks to (verified by twoscale_tables.bundle), and Dr.Jit
building blocks: axis encodings, opaque numbers, flat buffers and their gathers, the density a quantile row
realises, and log1p / expm1 (Dr.Jit has neither).

The arithmetic here is Dr.Jit's, so it runs in symbolic and evaluated modes, in JIT and scalar variants,
and passes gradients through its coordinates.
"""
import contextlib
import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
from twoscale_tables import bundle as tables_bundle

LAMBDA_RANGE = (0.36, 0.83)  # micrometres: Mitsuba's spectral range


class TwoScaleError(ValueError):
    """A bad parameter, a missing table or a corrupt one: one line says which."""


@contextlib.contextmanager
def unpacked(bundle, public_key=None):
    """The folder holding a bundle's (.tar.gz) tables, removed on exit (its tables are read into memory inside):
    twoscale_tables.bundle's checks passed (with public_key, a minisign .pub file or its base64 line, the
    signature first)."""
    with contextlib.ExitStack() as stack:
        try:
            folder = stack.enter_context(tables_bundle.unpacked(bundle, public_key))
        except ValueError as e:  # one line naming the bundle or its signature
            raise TwoScaleError(str(e)) from None
        yield folder


@contextlib.contextmanager
def table_folder(tables, public_key=None):
    """(folder, bundle) of `tables`: a folder as it is (bundle None), or the one a bundle unpacks to (`unpacked`;
    bundle its path); public_key only with a bundle."""
    path = Path(tables)
    if path.is_file() and path.name.endswith(".tar.gz"):
        with unpacked(path, public_key) as folder:
            yield folder, path
        return
    if public_key is not None:
        raise TwoScaleError(f"twoscale: public_key verifies a bundle's signature, but {tables} is not a bundle (.tar.gz)")
    yield path, None


def encode(enc, x):
    """An axis encoding e(x) in Dr.Jit (pipeline/tables/python/twoscale_tables/_axes.py's numpy one); x finite.
    bounded_log and bounded_log_tan, which reach +inf, are written in (sin, cos) by their callers."""
    kind = enc["kind"]
    if kind == "linear":
        return x
    if kind == "log":
        return dr.log(x)
    if kind == "reciprocal":
        return dr.rcp(x)
    if kind == "shifted_log":
        return dr.log(x - enc["shift"])
    if kind == "log_gap":
        return -dr.log(enc["end"] + enc["eps"] - x)
    if kind == "log1p_sq":
        s = x / enc["scale"]
        return log1p(s * s)
    if kind == "log_plus_log_log1p_sq":
        return dr.log(x) + dr.log(log1p(x * x))
    if kind == "asin_sqrt":
        return dr.safe_asin(dr.safe_sqrt(x))
    raise TwoScaleError(f"axis encoding {kind!r} is not one this BSDF reads")


def bounded_log_tan(enc, sin_t, cos_t):
    """ln((tan theta + eps)/(1 + delta tan theta)) written in (sin, cos): finite at the horizon. With sin_t scaled by
    beta it is bounded_log of a = beta tan theta (epd_g1's axis)."""
    return dr.log((sin_t + enc["eps"] * cos_t) / (cos_t + enc["delta"] * sin_t))


def lobe_angle(theta_h, u, edge_d, theta_cap, v_anchor):
    """The stored angle v_theta of zh_lobe (docs/maths.md section 4b): with the edge a = min(sqrt(1/(1 + 4u^2) +
    edge_d^2), theta_cap), v_anchor ln(1 + theta_h/a) / ln 2 up to a, then v_anchor + (1 - v_anchor) ln(theta_h/a) /
    ln((pi/2)/a). edge_d is the material's number, or atan(beta k^(1/(2p))) of the general table."""
    a = dr.minimum(dr.sqrt(1.0 / (1.0 + 4.0 * u * u) + edge_d * edge_d), theta_cap)
    inner = v_anchor * log1p(theta_h / a) / math.log(2.0)
    outer = v_anchor + (1.0 - v_anchor) * dr.log(dr.maximum(theta_h, a) / a) / dr.log((math.pi / 2) / a)
    return dr.select(theta_h <= a, inner, outer)


def log1p(x):
    """ln(1 + x), accurate for small x in float32 (Goldberg: ln(u) x / (u - 1) with u = 1 + x)."""
    u = 1.0 + x
    d = u - 1.0
    return dr.select(d == 0.0, x, dr.log(u) * x / dr.select(d == 0.0, 1.0, d))


def expm1(x):
    """e^x - 1, accurate for small x in float32 (Kahan: (u - 1) x / ln u with u = e^x)."""
    u = dr.exp(x)
    d = u - 1.0
    ln_u = dr.log(u)
    small = (d == 0.0) | (ln_u == 0.0)
    return dr.select(small, x, dr.select(u == 0.0, -1.0, d * x / dr.select(small, 1.0, ln_u)))


def opaque(x):
    """A number as an opaque Dr.Jit value: a kernel reads it instead of having it compiled in, so that materials
    (and parameter updates) share kernels rather than each compiling its own."""
    return dr.opaque(mi.Float, float(x))


def buffer(array):
    """A flat read-only buffer of an array's float32 values (C order), read with `gather`."""
    return mi.Float(array.ravel()) if dr.is_jit_v(mi.Float) else dr.scalar.ArrayXf(array.ravel())


def gather(buf, i):
    return dr.gather(mi.Float, buf, i) if dr.is_jit_v(mi.Float) else buf[i]


def quantile_density(buf, row, n, theta, weights=None):
    """The density of theta that interpolating a quantile row realises (docs/runtimes.md): the row's nodes at
    `row` (+ (row2, t) for a row interpolated between two), found by binary search."""
    def q(j):
        if weights is None:
            return gather(buf, row + j)
        row2, t = weights
        return dr.lerp(gather(buf, row + j), gather(buf, row2 + j), t)

    j = dr.binary_search(1, n - 1, lambda j: q(j) <= theta) - 1
    q0, q1 = q(j), q(j + 1)
    dq = dr.maximum(q1 - q0, 1e-30)
    h = (math.pi / 2) / (n - 1)
    e = (mi.Float(j) + dr.clip((theta - q0) / dq, 0.0, 1.0)) * h
    return dr.select((theta >= 0) & (theta <= q1), dr.sin(2.0 * e) * h / dq, 0.0)
