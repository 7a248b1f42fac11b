"""Axis encodings and derived axes (docs/file_contract.md), over numpy arrays.

Each function mirrors pipeline/tables/src/axis.rs or derived.rs operation by operation.
"""
import math

import numpy as np

LN_2 = math.log(2.0)
FRAC_PI_2 = math.pi / 2


def encode(enc, x):
    """The encoding e(x) of an axis (manifest `axes[].encoding`), element-wise; finite at 0 and +inf
    where the encoding says so."""
    kind = enc["kind"]
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(all="ignore"):
        if kind == "linear":
            return x.copy()
        if kind == "log":
            return np.log(x)
        if kind == "reciprocal":
            return 1.0 / x
        if kind == "exp_neg_power":
            return np.exp(-np.power(x, -1.0 / enc["k"]))
        if kind == "bounded_log":
            return _bounded_log(x, enc["eps"], enc["delta"])
        if kind == "shifted_reciprocal":
            return 1.0 / (x + enc["shift"])
        if kind == "shifted_log":
            return np.log(x - enc["shift"])
        if kind == "log_gap":
            return -np.log(enc["end"] + enc["eps"] - x)
        if kind == "log_plus_log_log1p_sq":
            return np.log(x) + np.log(np.log1p(x * x))
        if kind == "log1p_sq":
            s = x / enc["scale"]
            return np.log1p(s * s)
        if kind == "bounded_log_tan":
            return _bounded_log(np.tan(x), enc["eps"], enc["delta"])
        if kind == "asin_sqrt":
            return np.arcsin(np.sqrt(x))
    raise ValueError(f"unknown axis encoding {kind!r}")


def _bounded_log(x, eps, delta):
    """ln((x + eps) / (1 + delta x)), and -ln(delta) at +inf."""
    return np.where(x == math.inf, -math.log(delta), np.log((x + eps) / (1.0 + delta * x)))


# The inputs of each lobe angle, in the manifest's order (checked by `open`).
LOBE_ANGLES = {"anchored_lobe_angle": ["u", "p", "beta"], "material_lobe_angle": ["u"]}


def lobe_edge(d, inputs):
    """The edge theta_a of a lobe angle: min(sqrt(1/(1 + 4u^2) + wd^2), theta_cap), with
    wd = atan(beta k^(1/(2p))) (`anchored_lobe_angle`, inputs u, p, beta) or the material's
    `edge_d` (`material_lobe_angle`, input u)."""
    u = inputs[0]
    if d["kind"] == "anchored_lobe_angle":
        wd = np.arctan(inputs[2] * np.power(d["k"], 0.5 / inputs[1]))
    else:
        wd = d["edge_d"]
    return np.minimum(np.sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), d["theta_cap"])


def derive(d, x, inputs):
    """A derived axis (manifest `derived_axes[]`): the stored coordinate of the physical coordinate
    `x`, given the physical coordinates `inputs` (in the order of the manifest's `inputs`)."""
    if d["kind"] not in LOBE_ANGLES:
        raise ValueError(f"unknown derived axis {d['kind']!r}")
    x = np.asarray(x, dtype=np.float64)
    a, va = lobe_edge(d, inputs), d["v_anchor"]
    with np.errstate(all="ignore"):
        inner = va * np.log1p(x / a) / LN_2
        outer = va + (1.0 - va) * np.log(x / a) / np.log(FRAC_PI_2 / a)
    return np.where(x <= a, inner, outer)
