"""The explorer's bake (runtimes/webgl/README.md "The bake"): the grid it tabulates ln C on, chosen by this
measurement (the table in docs/benchmarks.md "The bake"). For random (c, p, beta0, u_max), zh_lobe's own lookup
is tabulated on (beta layer, u, v) nodes over beta in [beta0/4, 4 beta0] (a beta map's range) and u in [0, u_max],
then interpolated as ts_bk_ln_lobe does (trilinear, v at the point shared by the corners) and compared with the
lookup itself at random (u, beta, theta).

    .venv/bin/python runtimes/webgl/tools/bake_frontier.py --tables tables-out/default

Relative error of C where C >= 1e-4 of the set's largest; 12 sets of 4,000 points.
"""
import argparse
import math
from pathlib import Path

import numpy as np
from general_frontier import theta_of  # beside this script
from twoscale_tables import Table, derive  # the reader package (`make pyenv` installs it)

GRIDS = [(33, 16, 129), (65, 16, 257), (65, 32, 129), (65, 32, 257), (65, 64, 257), (129, 32, 513)]
SCALE = 0.5  # the u axis: log1p_sq of this scale, as the material exports'


def cell(nodes, x):
    f = np.clip((x - nodes[0]) / (nodes[1] - nodes[0]), 0, len(nodes) - 1)
    i = np.minimum(f.astype(int), len(nodes) - 2)
    return i, f - i


def measure(t, grid, sets=12, n=4000, seed=61):
    nu, nb, nv = grid
    d, rng, errs = t.manifest["derived_axes"][0], np.random.default_rng(seed), []

    def lookup(u, c, p, beta, theta):
        u, c, p, beta, theta = np.broadcast_arrays(u, c, p, beta, theta)
        return t.lookup_arrays({"u": u, "c": c, "p": p, "beta": beta, "theta_h": theta}, ["c_lobe"])["c_lobe"]

    for _ in range(sets):
        c, p = rng.uniform(1.02, 3.0), math.exp(rng.uniform(math.log(0.35), math.log(5.0)))
        beta0, u_max = math.exp(rng.uniform(math.log(0.005), math.log(0.5))), rng.uniform(0.5, 100.0)
        lb = np.linspace(math.log(max(beta0 / 4, 0.005)), math.log(min(4 * beta0, 0.5)), nb)
        eu = np.linspace(0.0, math.log1p((u_max / SCALE) ** 2), nu)
        un, vn = SCALE * np.sqrt(np.expm1(eu)), np.linspace(0.0, 1.0, nv)
        uu, bb, vv = np.meshgrid(un, np.exp(lb), vn, indexing="ij")
        ln_c = np.log(lookup(uu, c, p, bb, theta_of(d, vv, uu, p, bb)))
        u = SCALE * np.sqrt(np.expm1(rng.uniform(0.0, eu[-1], n)))
        beta = np.exp(rng.uniform(lb[0], lb[-1], n))
        theta = np.arcsin(1.0 - rng.integers(0, 1000, n) / 1000.0)
        ref = lookup(u, c, p, beta, theta)
        (iu, tu), (ib, tb) = cell(eu, np.log1p((u / SCALE) ** 2)), cell(lb, np.log(beta))
        iv, tv = cell(vn, derive(d, theta, [u, np.full(n, p), beta]))
        got = 0.0
        for du in (0, 1):
            for db in (0, 1):
                w = (tu if du else 1 - tu) * (tb if db else 1 - tb)
                got = got + w * ((1 - tv) * ln_c[iu + du, ib + db, iv] + tv * ln_c[iu + du, ib + db, iv + 1])
        keep = ref >= 1e-4 * ref.max()
        errs.append(np.abs(np.exp(got) - ref)[keep] / ref[keep])
    e = np.concatenate(errs)
    return np.median(e), np.percentile(e, 99), e.max()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tables", type=Path, default=Path("tables-out/default"))
    a = ap.parse_args()
    t = Table.open(a.tables / "zh_lobe.h5")
    print("| u x beta x v nodes | texels | median | p99 | max |\n|---|---|---|---|---|")
    for g in GRIDS:
        med, p99, mx = measure(t, g)
        print(f"| {g[0]} x {g[1]} x {g[2]} | {g[0] * g[1] * g[2] / 1e6:.2f} M | {med:.1e} | {p99:.1e} | {mx:.1e} |")


if __name__ == "__main__":
    main()
