"""zh_lobe for a GPU: size against accuracy of the representations the general export could use (issue 61; the
table in docs/benchmarks.md "The general export for GPUs"). Each choice is decoded in numpy at the same random
points and compared with zh_lobe's own lookup (float32 ln C and its four stored control variates).

    .venv/bin/python runtimes/webgl/tools/general_frontier.py --tables tables-out/default

Points: 600 (u, c, p, beta) uniform in the encoded axes, each at 200 angles sin theta_h = 1 - k/1000 (k random);
relative error where C >= 1e-4 of the point's largest over its angles. "terms at corners": the reader computes the
control-variate terms at the cell's 32 nodes itself (what the stored cv_* hold), so only one value per node is
stored; "residual": that value is ln C - M, M = sum_j alpha_j t_j at the node (the export's choice).
"""
import argparse
import itertools
import math
import warnings
from pathlib import Path

import numpy as np
from twoscale_tables import Table, _lobe, derive, encode  # the reader package (`make pyenv` installs it)


def theta_of(d, v, u, p, beta):
    """The inverse of the derived angle axis: theta at stored coordinate v."""
    a = np.minimum(np.sqrt(1.0 / (1.0 + 4.0 * u * u) + np.arctan(beta * np.power(d["k"], 0.5 / p)) ** 2), d["theta_cap"])
    va = d["v_anchor"]
    inner = a * np.expm1(v / va * math.log(2.0))
    outer = a * np.exp((v - va) / (1.0 - va) * np.log(math.pi / 2 / a))
    return np.minimum(np.where(v <= va, inner, outer), math.pi / 2)


class Study:
    def __init__(self, tables, n_points=600, n_angles=200, seed=61):
        self.t = Table.open(Path(tables) / "zh_lobe.h5")
        self.fit = Table.open(Path(tables) / "zh_convolution.h5")
        m, ax = self.t.manifest, self.t.axes
        self.d = m["derived_axes"][0]
        self.cvs = [cv["values"] for cv in m["value_encoding"][0]["control_variates"]]
        self.s = self.t.values["c_lobe"].astype(np.float64)
        grid = np.meshgrid(*ax, indexing="ij", sparse=True)
        alpha = _lobe.weights(grid[0], grid[2], grid[3], grid[4])
        self.model = sum(np.where(a != 0.0, a * self.t.values[c].astype(np.float64), 0.0) for a, c in zip(alpha, self.cvs))
        rng = np.random.default_rng(seed)
        par = [np.interp(rng.uniform(e[0], e[-1], n_points), e, x)[:, None] for e, x in zip(self.t.encoded[:4], ax[:4])]
        theta = np.arcsin(1.0 - rng.integers(0, 1000, (n_points, n_angles)) / 1000.0)
        self.pt = {k: np.broadcast_to(x, theta.shape) for k, x in zip(("u", "c", "p", "beta", "theta_h"), par + [theta])}
        self.v = derive(self.d, theta, [self.pt["u"], self.pt["p"], self.pt["beta"]])
        self.ref = self.t.lookup_arrays(self.pt, ["c_lobe"])["c_lobe"]
        self.keep = self.ref >= 1e-4 * self.ref.max(axis=1, keepdims=True)

    def nodes(self):
        return self.s.size

    def error(self, got):
        rel = np.abs(got - self.ref)[self.keep] / self.ref[self.keep]
        return np.median(rel), np.percentile(rel, 99), rel.max()

    def corners(self, stored, model_added, keep=None):
        """exp(I[stored] + [I[M]] + sum_j alpha_j (t_j - I[t_j])), the terms computed at the corners; `keep`: {axis:
        node indices} of the nodes kept (a coarser grid)."""
        keep = keep or {}
        ax = [x[keep[i]] if i in keep else x for i, x in enumerate(self.t.axes)]
        idx = np.ix_(*[keep.get(i, np.arange(len(x))) for i, x in enumerate(self.t.axes)])
        sv = stored[idx]
        x = [self.pt[k] for k in ("u", "c", "p", "beta")] + [self.v]
        cells = []
        for a, nodes, xi in zip(self.t.manifest["axes"], ax, x):
            enc, e = encode(a["encoding"], nodes), encode(a["encoding"], xi)
            up = np.clip(np.searchsorted(enc, e, side="right"), 1, len(enc) - 1)
            cells.append((up - 1, np.clip((e - enc[up - 1]) / (enc[up] - enc[up - 1]), 0.0, 1.0)))
        ln_c, iq = 0.0, [0.0] * 4
        for corner in itertools.product((0, 1), repeat=5):
            w, node = 1.0, []
            for (i, t), bit in zip(cells, corner):
                w, node = w * (t if bit else 1.0 - t), node + [i + bit]
            uk, ck, pk, bk, vk = (ax[k][node[k]] for k in range(5))
            t = _lobe.terms(theta_of(self.d, vk, uk, pk, bk), uk, ck, pk, bk)
            ln_c = ln_c + w * sv[tuple(node)]
            if model_added:
                alpha = _lobe.weights(uk, pk, bk, vk)
                ln_c = ln_c + w * sum(np.where(a != 0.0, a * tj, 0.0) for a, tj in zip(alpha, t))
            iq = [s + w * tj for s, tj in zip(iq, t)]
        p = self.pt
        return np.exp(ln_c + _lobe.correction(p["theta_h"], p["u"], p["c"], p["p"], p["beta"], self.v, iq))

    def plain(self, stored):
        """exp of the interpolated ln C, no control variates."""
        m = dict(self.t.manifest, value_encoding=[{"value": "c_lobe", "kind": "ln", "formula": "exp"}])
        m["values"] = [v for v in m["values"] if v["name"] == "c_lobe"]
        return Table(m, self.t.axes, {"c_lobe": stored.astype(np.float32)}).lookup_arrays(self.pt, ["c_lobe"])["c_lobe"]

    def fitted(self):
        """zh_convolution's plain fitted lobe s (1 + 4 g^2 sin^2)^(-(c+1)/2)."""
        p = self.pt
        f = self.fit.lookup_arrays({k: p[k] for k in ("u", "c", "p", "beta")}, ["s", "g"])
        return f["s"] * (1.0 + 4.0 * f["g"] ** 2 * np.sin(p["theta_h"]) ** 2) ** (-(p["c"] + 1.0) / 2.0)


def f16(x):
    return x.astype(np.float16).astype(np.float64)


def f32(x):
    return x.astype(np.float32).astype(np.float64)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tables", default="tables-out/default", help="the default preset's folder")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    st = Study(args.tables)
    n = st.nodes()
    r = st.s - st.model
    # Every second node, and the last (the domain's edge) where every second misses it.
    every = {i: np.unique(np.r_[0:len(x):2, len(x) - 1]) for i, x in enumerate(st.t.axes)}
    rows = [
        ("ln C float32 and its 4 control variates stored (the table)", 5 * 4 * n, lambda: st.ref),
        ("ln C float32, terms at corners", 4 * n, lambda: st.corners(f32(st.s), False)),
        ("residual float16, terms at corners (the export)", 2 * n, lambda: st.corners(f16(r), True)),
        ("ln C float16, terms at corners", 2 * n, lambda: st.corners(f16(st.s), False)),
    ]
    for i, name in enumerate(("u", "c", "p", "beta", "v_theta")):
        sub = every[i].size
        rows.append((f"residual float16, {name}: every 2nd node ({sub} of {st.t.axes[i].size})",
                     2 * n * sub // st.t.axes[i].size, lambda i=i: st.corners(f16(r), True, {i: every[i]})))
    rows += [
        ("ln C float32, no control variates", 4 * n, lambda: st.plain(f32(st.s))),
        ("zh_convolution's fitted lobe (s, g) instead", sum(st.fit.values[k].nbytes for k in ("s", "g")),
         st.fitted),
    ]
    print("| zh_lobe as | MB | median | p99 | max |\n|---|---|---|---|---|")
    for label, size, f in rows:
        med, p99, mx = st.error(f())
        print(f"| {label} | {size / 1e6:.1f} | {med:.1e} | {p99:.1e} | {mx:.1e} |", flush=True)


if __name__ == "__main__":
    main()
