#!/usr/bin/env python3
"""Read twoscale tables without twoscale: verify the data checksums against the
manifest beside the file, and interpolate exactly as `twoscale lookup` does
(multilinear in the encoded coordinates of each axis).

    python3 twoscale_tables.py lookup FILE.h5 NAME=VALUE ...   # prints {"table": ..., "values": {...}}

As a module: `Table.open("tables-out/default/epd_g1.h5").lookup({"p": 1.5, "a": 0.7})`, or
vectorised over numpy arrays (same numbers, bit for bit): `.lookup_arrays({"p": ps, "a": as_})`.
Needs numpy and h5py. Exit status: 0, 1 (unreadable or corrupt table), 2 (bad point).
"""
import hashlib
import json
import math
import sys
from pathlib import Path

import h5py
import numpy as np


def encode(enc, x):
    """The encoding e(x) of an axis (manifest `axes[].encoding`), finite at 0 and +inf where it says so."""
    kind = enc["kind"]
    with np.errstate(all="ignore"):
        x = np.float64(x)
        if kind == "linear":
            return x
        if kind == "log":
            return np.log(x)
        if kind == "reciprocal":
            return 1.0 / x
        if kind == "exp_neg_power":
            return np.exp(-np.power(x, -1.0 / enc["k"]))
        if kind == "bounded_log":
            # e(+inf) = -ln delta, element-wise so that arrays encode like scalars.
            e = np.where(np.isinf(x), -np.log(enc["delta"]), np.log((x + enc["eps"]) / (1.0 + enc["delta"] * x)))
            return e if e.ndim else np.float64(e)
        if kind == "shifted_reciprocal":
            return 1.0 / (x + enc["shift"])
        if kind == "shifted_log":
            return np.log(x - enc["shift"])
        if kind == "log_gap":
            return -np.log(enc["end"] + enc["eps"] - x)
        if kind == "log_plus_log_log1p_sq":
            return np.log(x) + np.log(np.log1p(x * x))
        if kind == "log1p_sq":
            return np.log1p((x / enc["scale"]) ** 2)
        if kind == "bounded_log_tan":
            t = np.tan(x)
            return np.log((t + enc["eps"]) / (1.0 + enc["delta"] * t))
        if kind == "asin_sqrt":
            return np.arcsin(np.sqrt(x))
    raise ValueError(f"unknown encoding {kind!r}")


def _lobe_edge(d, u, beta=None, p=None):
    """The edge a of `anchored_lobe_angle`: min(sqrt(1/(1 + 4u^2) + atan(beta k^(1/(2p)))^2), theta_cap);
    of `material_lobe_angle` (beta and p fixed): min(sqrt(1/(1 + 4u^2) + edge_d^2), theta_cap)."""
    wd = d["edge_d"] if d["kind"] == "material_lobe_angle" else math.atan(beta * math.pow(d["k"], 0.5 / p))
    return min(math.sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), d["theta_cap"])


LOBE_ANGLES = ("anchored_lobe_angle", "material_lobe_angle")


def derive(d, x, inputs):
    """A derived axis (manifest `derived_axes[]`): the stored coordinate of physical `x`."""
    if d["kind"] in LOBE_ANGLES:
        a, va = _lobe_edge(d, *inputs), d["v_anchor"]
        if x <= a:
            return va * math.log1p(x / a) / math.log(2.0)
        return va + (1.0 - va) * math.log(x / a) / math.log((math.pi / 2) / a)
    raise ValueError(f"unknown derived axis {d['kind']!r}")


# zh_lobe's value encodings `ln_control_variates_epd`, `ln_control_variates_tails` (0.6.0) and
# `ln_control_variates` (0.5.0; their manifest `formula`): ln C is interpolated after subtracting at
# each corner t = (1 - w) (mu logaddexp(ln m_S + ln D, b') + (lambda - mu) ln m_S + (1 - lambda) b)
# + w logaddexp(ln m_S + ln D, b) (mu = 0 without the EPD's shape in the core term, w = 0 without the
# tail term), then t at the point is added.
LOBE_COORDINATES = ["u", "c", "p", "beta", "theta_h"]
CV_KINDS = {"ln_control_variates": (False, False), "ln_control_variates_tails": (False, True), "ln_control_variates_epd": (True, True)}


def cv_weight(u, p, beta):
    """lambda = (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2."""
    ws2 = 1.0 / (1.0 + 4.0 * u * u)
    wd = beta / (2.0 * p)
    wd2 = wd * wd
    r = wd2 / (ws2 + wd2)
    return r * r


def cv_ln_ms(u, c):
    """ln m_S(u, c)."""
    a = 4.0 * u * u
    if a < 1e-12:
        return math.log(math.pi)
    return math.log(math.pi * -math.expm1(0.5 * (1.0 - c) * math.log1p((2.0 * u) * (2.0 * u))) / (0.5 * a * (c - 1.0)))


def cv_ndf(p, beta):
    """b's factors that depend on (p, beta) only: (ln m_D, slope variance s2)."""
    s2 = 0.5 * beta * beta * math.exp(math.lgamma(2.0 / p) - math.lgamma(1.0 / p))
    return 2.0 * math.log(beta) - math.log(math.exp(math.log(p) - math.lgamma(1.0 / p)) / math.pi), s2


def cv_angle(theta, u, s2):
    """b's and b''s angle terms: (ln(1 + 4u^2 sin^2 theta), ln((cos^2 theta + s2)/(1 + s2)),
    ln(1 + 4u^2 (sin^2 theta + 2 s2/(1 + 2 s2))))."""
    sin, cos = math.sin(theta), math.cos(theta)
    rms = math.log1p(4.0 * u * u * (sin * sin + 2.0 * s2 / (1.0 + 2.0 * s2)))
    return math.log1p(4.0 * u * u * sin * sin), math.log((cos * cos + s2) / (1.0 + s2)), rms


def cv_ln_d(theta, u, p, beta):
    """ln D at e = min(sqrt(theta^2 + 1/(4 (1 + 4u^2))), pi/2): -(tan e / beta)^(2p) - 4 ln max(sin(pi/2 - e), 1e-300)."""
    e = min(math.sqrt(theta * theta + 0.25 / (1.0 + 4.0 * u * u)), math.pi / 2)
    return -math.pow(math.tan(e) / beta, 2.0 * p) - 4.0 * math.log(max(math.sin(math.pi / 2 - e), 1e-300))


def _smoothstep(y, a, b):
    x = min(max((y - a) / (b - a), 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def cv_tail_weight(v, p, beta):
    """w at stored angle v: smoothstep(v, 0.2, 0.5) (1 - smoothstep(-2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), -4, -1))."""
    ln_peak = -2.0 / p + 2.0 * math.log1p(beta * beta * math.pow(2.0 / p, 1.0 / p))
    return _smoothstep(v, 0.2, 0.5) * (1.0 - _smoothstep(ln_peak, -4.0, -1.0))


def cv_epd_weight(lam, p):
    """mu = lambda^2 smoothstep(p, 0.3, 0.5)."""
    return lam * lam * _smoothstep(p, 0.3, 0.5)


def _logaddexp(a, b):
    m = max(a, b)
    return m + math.log(math.exp(a - m) + math.exp(b - m))


def cv_t(lam, mu, w, ms, b, lse_rms, lse):
    """t from ln m_S, b, logaddexp(ln m_S + ln D, b') (`lse_rms`) and logaddexp(ln m_S + ln D, b) (`lse`):
    (1 - w) (mu lse_rms + (lambda - mu) ln m_S + (1 - lambda) b) + w lse."""
    core = lam * ms + (1.0 - lam) * b if mu == 0.0 else mu * lse_rms + (lam - mu) * ms + (1.0 - lam) * b
    return core if w == 0.0 else (1.0 - w) * core + w * lse


def cv_term(lam, mu, w, theta, u, c, p, beta):
    """t at (theta, u, c, p, beta)."""
    ln_md, s2 = cv_ndf(p, beta)
    spread, cos_term, spread_rms = cv_angle(theta, u, s2)
    k = 0.5 * (c + 1.0)
    ms, b, b_rms = cv_ln_ms(u, c), ln_md - k * spread + cos_term, ln_md - k * spread_rms + cos_term
    a = ms + cv_ln_d(theta, u, p, beta)
    return cv_t(lam, mu, w, ms, b, _logaddexp(a, b_rms), _logaddexp(a, b))


def _libm(f, *args):
    """Element-wise math.f: the libm calls `derive` and `decode` make (numpy's SIMD exp, log1p and
    pow can differ from them by an ulp, and the vectorised lookup must equal the scalar one)."""
    return np.frompyfunc(f, len(args), 1)(*args).astype(np.float64)


def cv_angle_arrays(theta, u, s2):
    """`cv_angle` over numpy arrays (the same operations, element by element)."""
    sin, cos = _libm(math.sin, theta), _libm(math.cos, theta)
    rms = _libm(math.log1p, 4.0 * u * u * (sin * sin + 2.0 * s2 / (1.0 + 2.0 * s2)))
    return _libm(math.log1p, 4.0 * u * u * sin * sin), _libm(math.log, (cos * cos + s2) / (1.0 + s2)), rms


def cv_ln_d_arrays(theta, u, p, beta):
    """`cv_ln_d` over numpy arrays (the same operations, element by element)."""
    e = np.minimum(np.sqrt(theta * theta + 0.25 / (1.0 + 4.0 * u * u)), math.pi / 2)
    return -_libm(math.pow, _libm(math.tan, e) / beta, 2.0 * p) - 4.0 * _libm(math.log, np.maximum(_libm(math.sin, math.pi / 2 - e), 1e-300))


def _smoothstep_arrays(y, a, b):
    x = np.clip((y - a) / (b - a), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def cv_tail_weight_arrays(v, p, beta):
    """`cv_tail_weight` over numpy arrays (the same operations, element by element)."""
    ln_peak = -2.0 / p + 2.0 * _libm(math.log1p, beta * beta * _libm(math.pow, 2.0 / p, 1.0 / p))
    return _smoothstep_arrays(v, 0.2, 0.5) * (1.0 - _smoothstep_arrays(ln_peak, -4.0, -1.0))


def _logaddexp_arrays(a, b):
    """`_logaddexp` over numpy arrays. libm is called only where |a - b| <= 40: beyond,
    exp(-|a - b|) < 2^-53 and the scalar log(1 + exp(-|a - b|)) is exactly 0."""
    m = np.maximum(a, b)
    out = m.copy()
    near = np.abs(a - b) <= 40.0
    out[near] = m[near] + _libm(math.log, _libm(math.exp, a[near] - m[near]) + _libm(math.exp, b[near] - m[near]))
    return out


def cv_t_arrays(lam, mu, w, ms, b, lse_rms, lse):
    """`cv_t` over numpy arrays (the same operations, element by element; lam, mu and w broadcast
    against ms)."""
    lam, mu, w, ms, b, lse_rms, lse = np.broadcast_arrays(lam, mu, w, ms, b, lse_rms, lse)
    out = lam * ms + (1.0 - lam) * b
    e, k = mu != 0.0, w != 0.0
    out[e] = mu[e] * lse_rms[e] + (lam[e] - mu[e]) * ms[e] + (1.0 - lam[e]) * b[e]
    out[k] = (1.0 - w[k]) * out[k] + w[k] * lse[k]
    return out


def cv_term_arrays(lam, mu, w, theta, u, c, p, beta):
    """`cv_term` over numpy arrays (the same operations, element by element); ln m_D and s2 once
    per distinct (p, beta), as a render's points share them."""
    pb, which = np.unique(p + 1j * beta, return_inverse=True)  # (1-D sorts far faster than rows)
    ln_md, s2 = np.array([cv_ndf(x.real, x.imag) for x in pb]).reshape(len(pb), 2)[which.reshape(-1)].T
    a = 4.0 * u * u
    ln_ms = np.full(a.shape, math.log(math.pi))
    k = a >= 1e-12
    uk, ck = u[k], c[k]
    ln_ms[k] = _libm(math.log, math.pi * -_libm(math.expm1, 0.5 * (1.0 - ck) * _libm(math.log1p, (2.0 * uk) * (2.0 * uk))) / (0.5 * a[k] * (ck - 1.0)))
    spread, cos_term, spread_rms = cv_angle_arrays(theta, u, s2)
    k = 0.5 * (c + 1.0)
    b, b_rms = ln_md - k * spread + cos_term, ln_md - k * spread_rms + cos_term
    a = ln_ms + cv_ln_d_arrays(theta, u, p, beta)
    return cv_t_arrays(lam, mu, w, ln_ms, b, _logaddexp_arrays(a, b_rms), _logaddexp_arrays(a, b))


def _lobe_edge_arrays(d, u, beta=None, p=None):
    """`_lobe_edge` over numpy arrays (the same operations, element by element)."""
    wd = d["edge_d"] if d["kind"] == "material_lobe_angle" else _libm(math.atan, beta * _libm(math.pow, d["k"], 0.5 / p))
    return np.minimum(np.sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), d["theta_cap"])


def derive_arrays(d, x, inputs):
    """`derive` over numpy arrays (the same operations, element by element)."""
    if d["kind"] in LOBE_ANGLES:
        a, va = _lobe_edge_arrays(d, *inputs), d["v_anchor"]
        inner = va * _libm(math.log1p, x / a) / math.log(2.0)
        beyond = np.maximum(x, a)  # the outer piece where it applies (math.log refuses 0)
        outer = va + (1.0 - va) * _libm(math.log, beyond / a) / _libm(math.log, (math.pi / 2) / a)
        return np.where(x <= a, inner, outer)
    raise ValueError(f"unknown derived axis {d['kind']!r}")


def underive_arrays(d, v, inputs):
    """The inverse of `derive` over numpy arrays: the physical coordinates at stored coordinates `v`."""
    if d["kind"] in LOBE_ANGLES:
        a, va = _lobe_edge_arrays(d, *inputs), d["v_anchor"]
        inner = a * _libm(math.expm1, v / va * math.log(2.0))
        outer = a * _libm(math.exp, (v - va) / (1.0 - va) * _libm(math.log, (math.pi / 2) / a))
        return np.minimum(np.where(v <= va, inner, outer), math.pi / 2)
    raise ValueError(f"unknown derived axis {d['kind']!r}")


def decode_arrays(enc, stored):
    """`decode` over numpy arrays (control variates: `stored` already holds the t at the point)."""
    if enc["kind"] == "ln" or enc["kind"] in CV_KINDS:
        return _libm(math.exp, stored)
    raise ValueError(f"unknown value encoding {enc['kind']!r}")


def decode(enc, stored):
    """A stored value's encoding (manifest `value_encoding[]`): the physical value
    (control variates: `stored` already holds the t at the point)."""
    if enc["kind"] == "ln" or enc["kind"] in CV_KINDS:
        return math.exp(stored)
    raise ValueError(f"unknown value encoding {enc['kind']!r}")


def verify_file(path, manifest):
    """Checks `path` against the manifest's `file` entry: its name, size, then SHA-256."""
    entry = manifest["file"]
    if entry["path"] != path.name:
        raise ValueError(f"{path}: the manifest describes {entry['path']!r}")
    if path.stat().st_size != entry["bytes"]:
        raise ValueError(f"{path} has {path.stat().st_size} bytes, the manifest says {entry['bytes']}")
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    if h.hexdigest() != entry["sha256"]:
        raise ValueError(f"{path}: file checksum differs from the manifest")


def _check_manifest(m, table):
    """The fields a lookup reads, with their types (ValueError naming the first that is wrong)."""
    def need(cond, what):
        if not cond:
            raise ValueError(what)

    def is_str(x):
        return isinstance(x, str)

    need(isinstance(m, dict), "not a JSON object")
    need(m.get("format") == "twoscale-manifest/1", f"format {m.get('format')!r}, not 'twoscale-manifest/1'")
    need(m.get("table") == table, f"it is for table {m.get('table')!r}, not {table!r}")
    f = m.get("file")
    need(isinstance(f, dict) and is_str(f.get("path")) and type(f.get("bytes")) is int and is_str(f.get("sha256")), "bad `file` entry")
    for key, fields in (("axes", ("name", "sha256")), ("values", ("name", "sha256", "dtype"))):
        need(isinstance(m.get(key), list) and m[key], f"`{key}` is not a non-empty list")
        for e in m[key]:
            need(isinstance(e, dict) and all(is_str(e.get(k)) for k in fields), f"bad entry in `{key}`")
    for a in m["axes"]:
        need(isinstance(a.get("encoding"), dict) and is_str(a["encoding"].get("kind")), f"axis {a['name']}: bad encoding")
        need(type(a.get("size")) is int and all(isinstance(a.get(k), (int, float, str)) for k in ("min", "max")), f"axis {a['name']}: bad size or range")
    for v in m["values"]:
        need(isinstance(v.get("shape"), list), f"value {v['name']}: bad shape")
    for key in ("derived_axes", "value_encoding"):
        need(isinstance(m.get(key, []), list) and all(isinstance(e, dict) for e in m.get(key, [])), f"bad `{key}`")


def _contract(m):
    """What the file's attribute `contract` records of the manifest: axes in order with their
    encodings, value names, derived axes and value encodings."""
    return {
        "axes": [{"name": a["name"], "encoding": a["encoding"]} for a in m["axes"]],
        "values": [v["name"] for v in m["values"]],
        "derived_axes": m.get("derived_axes", []),
        "value_encoding": m.get("value_encoding", []),
    }


def _json_f64(x):
    """A manifest number (+inf is the string "inf")."""
    return {"inf": math.inf, "-inf": -math.inf}[x] if isinstance(x, str) else float(x)


def sha256(array, dtype):
    """SHA-256 of the canonical bytes: little-endian, C order."""
    return hashlib.sha256(np.ascontiguousarray(array, dtype=dtype).tobytes()).hexdigest()


# A cell's 32 corners (bit d: the upper node along axis d), the 16 of them with the lower c node,
# at which the angle terms (independent of c) are computed, and each corner's one among those.
_CORNER_BITS = (np.arange(32)[:, None] >> np.arange(5)) & 1
_ANGLE_CORNERS = np.array([k for k in range(32) if not k & 2])
_ANGLE_OF = np.searchsorted(_ANGLE_CORNERS, np.arange(32) & ~2)


class Table:
    def __init__(self, manifest, axes, values):
        self.manifest, self.axes, self.values = manifest, axes, values
        self.encoded = [np.array([encode(a["encoding"], x) for x in nodes]) for a, nodes in zip(manifest["axes"], axes)]
        # Values decoded with zh_lobe's control variates (value -> (with the EPD's shape in the core term, with the tail term)),
        # and the derived angle axis they read.
        self.cv = {e["value"]: CV_KINDS[e["kind"]] for e in manifest.get("value_encoding", []) if e["kind"] in CV_KINDS}
        if self.cv:
            derived = manifest.get("derived_axes", [])
            if self.coordinates() != LOBE_COORDINATES or len(derived) != 1 or derived[0]["axis"] != manifest["axes"][4]["name"]:
                kind = next(e["kind"] for e in manifest["value_encoding"] if e["kind"] in CV_KINDS)
                raise ValueError(f"value encoding {kind} needs the coordinates {', '.join(LOBE_COORDINATES)} (theta_h derived)")
            self.cv_axis = derived[0]
            # The corner terms' factors at the nodes: ln m_S per (u, c), (ln m_D, s2) per (p, beta).
            self._cv_ms = np.array([[cv_ln_ms(float(u), float(c)) for c in axes[1]] for u in axes[0]])
            self._cv_ndf = np.array([[cv_ndf(float(p), float(b)) for b in axes[3]] for p in axes[2]])

    def _cv_nodes(self, cells):
        """(ln m_S, b, logaddexp(ln m_S + ln D, b'), logaddexp(ln m_S + ln D, b)), each of shape (len(cells), 32), at the 32 corners of the cells with lower node
        indices `cells` (rows of 5; corner bit d: the upper node along axis d of u, c, p, beta,
        v_theta). ln m_S, ln m_D and s2 come from the node tables made by __init__; the angle terms
        and ln D are computed once per (u, p, beta, v_theta) corner, for all cells at once; the term at a corner is `cv_t` of them."""
        node = np.asarray(cells, dtype=np.intp).reshape(-1, 1, 5) + _CORNER_BITS  # (cells, 32, axis)
        ms = self._cv_ms[node[..., 0], node[..., 1]]
        ndf = self._cv_ndf[node[..., 2], node[..., 3]]
        at = node[:, _ANGLE_CORNERS]
        u = self.axes[0][at[..., 0]]
        theta = underive_arrays(self.cv_axis, self.axes[4][at[..., 4]], [u, self.axes[3][at[..., 3]], self.axes[2][at[..., 2]]])
        spread, cos_term, spread_rms = cv_angle_arrays(theta, u, ndf[:, _ANGLE_CORNERS, 1])
        ln_d = cv_ln_d_arrays(theta, u, self.axes[2][at[..., 2]], self.axes[3][at[..., 3]])
        k = 0.5 * (self.axes[1][node[..., 1]] + 1.0)
        cos_term = cos_term[:, _ANGLE_OF]
        b, b_rms = ndf[..., 0] - k * spread[:, _ANGLE_OF] + cos_term, ndf[..., 0] - k * spread_rms[:, _ANGLE_OF] + cos_term
        a = ms + ln_d[:, _ANGLE_OF]
        return ms, b, _logaddexp_arrays(a, b_rms), _logaddexp_arrays(a, b)

    @classmethod
    def open(cls, path):
        """Reads FILE.h5 and FILE.manifest.json beside it; raises ValueError on any checksum mismatch.
        The file's size and SHA-256 are checked against the manifest before h5py opens it (the HDF5
        library can crash or hang on a malformed file), then every data checksum, and the manifest's
        axes, values and encodings against the file's own record of them (attribute `contract`)."""
        path = Path(path)
        if path.suffix != ".h5":
            raise ValueError(f"{path}: a table file ends in .h5")
        mpath = path.with_name(path.name[: -len(".h5")] + ".manifest.json")
        try:
            manifest = json.loads(mpath.read_text())
            _check_manifest(manifest, path.name[: -len(".h5")])
        except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as e:
            raise ValueError(f"{mpath}: malformed manifest: {e}") from None
        verify_file(path, manifest)
        with h5py.File(path, "r") as f:
            if "contract" not in f.attrs:
                raise ValueError(f"{path} has no attribute `contract` (written before twoscale 0.8.0): rebuild it")
            contract = json.loads(f.attrs["contract"])
            axes = [np.asarray(f["axes"][a["name"]][()], dtype="<f8") for a in manifest["axes"]]
            values = {v["name"]: np.asarray(f["values"][v["name"]][()], dtype="<f4") for v in manifest["values"]}
        if contract != _contract(manifest):
            raise ValueError(f"{mpath}: the contract (axis order and encodings, derived axes, value encodings) differs from the file {path}")
        for a, nodes in zip(manifest["axes"], axes):
            if sha256(nodes, "<f8") != a["sha256"]:
                raise ValueError(f"{path}: axis {a['name']} does not match its manifest checksum")
            if nodes.ndim != 1 or a["size"] != len(nodes) or _json_f64(a["min"]) != nodes.min() or _json_f64(a["max"]) != nodes.max():
                raise ValueError(f"{mpath}: axis {a['name']}'s entry (size, range) differs from the file {path}")
        for v in manifest["values"]:
            data = values[v["name"]]
            if sha256(data, "<f4") != v["sha256"]:
                raise ValueError(f"{path}: values/{v['name']} does not match its manifest checksum")
            if v["dtype"] != "float32" or list(data.shape) != v["shape"] or data.shape != tuple(len(x) for x in axes):
                raise ValueError(f"{mpath}: values/{v['name']}'s entry (dtype, shape) differs from the file {path}")
        return cls(manifest, axes, values)

    def _locate(self, i, x):
        name, enc = self.manifest["axes"][i]["name"], self.encoded[i]
        e = encode(self.manifest["axes"][i]["encoding"], x)
        sign = 1.0 if enc[-1] > enc[0] else -1.0
        if math.isnan(x) or math.isnan(e) or sign * e < sign * enc[0] or sign * e > sign * enc[-1]:
            raise ValueError(f"{name} = {x} is outside the table's domain [{self.axes[i].min()}, {self.axes[i].max()}]")
        upper = int(np.searchsorted(sign * enc, sign * e, side="right"))
        upper = min(max(upper, 1), len(enc) - 1)
        cell = upper - 1
        t = (e - enc[cell]) / (enc[cell + 1] - enc[cell])
        return cell, min(max(float(t), 0.0), 1.0)

    def _locate_arrays(self, i, x):
        """_locate over an array of coordinates: (cells, t)."""
        name, enc = self.manifest["axes"][i]["name"], self.encoded[i]
        e = np.asarray(encode(self.manifest["axes"][i]["encoding"], x), dtype=np.float64)
        sign = 1.0 if enc[-1] > enc[0] else -1.0
        bad = np.isnan(x) | np.isnan(e) | (sign * e < sign * enc[0]) | (sign * e > sign * enc[-1])
        if bad.any():
            x0 = x[np.argmax(bad)]
            raise ValueError(f"{name} = {x0} is outside the table's domain [{self.axes[i].min()}, {self.axes[i].max()}]")
        upper = np.clip(np.searchsorted(sign * enc, sign * e, side="right"), 1, len(enc) - 1)
        cell = upper - 1
        t = (e - enc[cell]) / (enc[cell + 1] - enc[cell])
        return cell, np.clip(t, 0.0, 1.0)

    def coordinates(self):
        """The physical coordinates a lookup takes: each axis, or the coordinate a derived axis comes from."""
        derived = {d["axis"]: d["coordinate"] for d in self.manifest.get("derived_axes", [])}
        return [derived.get(a["name"], a["name"]) for a in self.manifest["axes"]]

    def _check_coordinates(self, point):
        """The coordinate names, after checking that `point` names each exactly once."""
        names = self.coordinates()
        unknown = set(point) - set(names)
        if unknown:
            raise ValueError(f"unknown axis {sorted(unknown)[0]!r} (axes: {', '.join(names)})")
        missing = [n for n in names if n not in point]
        if missing:
            raise ValueError(f"missing coordinate {missing[0]!r}")
        return names

    def lookup(self, point):
        """{value name: interpolated, decoded value} at point {coordinate name: physical value}."""
        names = self._check_coordinates(point)
        physical = [float(point[n]) for n in names]
        stored = list(physical)
        derived = {d["axis"]: d for d in self.manifest.get("derived_axes", [])}
        for i, a in enumerate(self.manifest["axes"]):
            d = derived.get(a["name"])
            if d is None:
                self._locate(i, stored[i])  # physical coordinates are checked before they are used
                continue
            x = stored[i]
            if math.isnan(x) or x < d["min"] or x > d["max"]:
                raise ValueError(f"{d['coordinate']} = {x} is outside the table's domain [{d['min']}, {d['max']}]")
            stored[i] = derive(d, x, [float(point[n]) for n in d["inputs"]])
        cells = [self._locate(i, x) for i, x in enumerate(stored)]
        out = {}
        for vname, data in self.values.items():
            lam = cv_weight(physical[0], physical[2], physical[3]) if vname in self.cv else None
            if lam is not None:
                epd, tails = self.cv[vname]
                mu = cv_epd_weight(lam, physical[2]) if epd else 0.0
                tail_w = cv_tail_weight(stored[4], physical[2], physical[3]) if tails else 0.0
                ms, b, lse_rms, lse = (x[0].tolist() for x in self._cv_nodes([cell for cell, _ in cells]))
                terms = [cv_t(lam, mu, tail_w, ms[k], b[k], lse_rms[k], lse[k]) for k in range(32)]
            total = 0.0
            for corner in range(1 << len(cells)):
                w, index = 1.0, []
                for d, (cell, t) in enumerate(cells):
                    up = (corner >> d) & 1
                    w *= t if up else 1.0 - t
                    index.append(cell + up)
                if w != 0.0:
                    x = float(data[tuple(index)])
                    if lam is not None:
                        x -= terms[corner]
                    total += w * x
            if lam is not None:
                total += cv_term(lam, mu, tail_w, *physical[4:], *physical[:4])
            out[vname] = total
        for enc in self.manifest.get("value_encoding", []):
            out[enc["value"]] = decode(enc, out[enc["value"]])
        return out

    def lookup_arrays(self, point, values=None):
        """{value name: ndarray} at the points {coordinate name: array-like} (broadcast together), for
        the named values (default: all); derived axes and value encodings as in `lookup`, the same
        arithmetic in the same order, so each element equals `lookup` exactly."""
        names = self._check_coordinates(point)
        coords = dict(zip(point, (c.ravel() for c in np.broadcast_arrays(*[np.asarray(point[n], dtype=np.float64) for n in point]))))
        shape = np.broadcast_shapes(*[np.shape(point[n]) for n in point])
        physical = [coords[n] for n in names]
        stored = list(physical)
        derived = {d["axis"]: d for d in self.manifest.get("derived_axes", [])}
        for i, a in enumerate(self.manifest["axes"]):
            d = derived.get(a["name"])
            if d is None:
                self._locate_arrays(i, stored[i])  # physical coordinates are checked before they are used
                continue
            x = stored[i]
            bad = np.isnan(x) | (x < d["min"]) | (x > d["max"])
            if bad.any():
                raise ValueError(f"{d['coordinate']} = {x[np.argmax(bad)]} is outside the table's domain [{d['min']}, {d['max']}]")
            stored[i] = derive_arrays(d, x, [coords[n] for n in d["inputs"]])
        cells = [self._locate_arrays(i, x) for i, x in enumerate(stored)]
        out = {}
        for vname in self.values if values is None else values:
            data = self.values[vname]
            lam = cv_weight(physical[0], physical[2], physical[3]) if vname in self.cv else None
            if lam is not None:  # (points, 32 corners), the node terms once per distinct cell
                epd, tails = self.cv[vname]
                mu = lam * lam * _smoothstep_arrays(physical[2], 0.3, 0.5) if epd else np.zeros_like(lam)
                tail_w = cv_tail_weight_arrays(stored[4], physical[2], physical[3]) if tails else np.zeros_like(lam)
                flat, which = np.unique(np.ravel_multi_index([c for c, _ in cells], data.shape), return_inverse=True)
                ms, b, lse_rms, lse = (x[which.reshape(-1)] for x in self._cv_nodes(np.stack(np.unravel_index(flat, data.shape), axis=1)))
                terms = cv_t_arrays(lam[:, None], mu[:, None], tail_w[:, None], ms, b, lse_rms, lse)
            total = np.zeros(cells[0][0].shape)
            for corner in range(1 << len(cells)):
                w, index = np.ones_like(total), []
                for d, (cell, t) in enumerate(cells):
                    up = (corner >> d) & 1
                    w = w * (t if up else 1.0 - t)
                    index.append(cell + up)
                x = data[tuple(index)].astype(np.float64)
                if lam is not None:
                    x = x - terms[:, corner]
                total = total + np.where(w != 0.0, w * x, 0.0)
            if lam is not None:
                total = total + cv_term_arrays(lam, mu, tail_w, physical[4], *physical[:4])
            out[vname] = total
        for enc in self.manifest.get("value_encoding", []):
            if enc["value"] in out:
                out[enc["value"]] = decode_arrays(enc, out[enc["value"]])
        return {k: v.reshape(shape) for k, v in out.items()}


def main(argv):
    if len(argv) < 3 or argv[1] != "lookup":
        print("usage: twoscale_tables.py lookup FILE.h5 NAME=VALUE ...", file=sys.stderr)
        return 2
    try:
        table = Table.open(argv[2])
    except Exception as e:  # any failure to read the table: one line, exit 1
        print(f"twoscale_tables: error: {e}".replace("\n", " "), file=sys.stderr)
        return 1
    try:
        point = {}
        for item in argv[3:]:
            name, _, value = item.partition("=")
            point[name] = float(value)
        values = table.lookup(point)
    except (ValueError, KeyError) as e:
        print(f"twoscale_tables: error: {e}", file=sys.stderr)
        return 2
    print(json.dumps({"table": table.manifest["table"], "values": values}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
