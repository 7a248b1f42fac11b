"""Tests of the `twoscale` BSDF's general mode: `tables` a preset folder (the default preset's general tables), every
parameter a float or a texture (docs/runtimes.md "General mode"). `pytest runtimes/mitsuba -k general`:

  agree     general mode with floats against the per-material BSDF of the same material, 7 materials, both lobes;
  texture   a nearest-filtered bitmap evaluates at each texel's centre as the float of its value;
  chi2      mitsuba.chi2 (sample() against pdf()) at those materials, theta_i 30 and 75 degrees (and 3 compensated);
  grad      forward-mode gradients of eval in beta, p, sigma_s, b, c against central differences; a bitmap's texels;
  furnace   energy = "compensated" over the domain: 1 without diffraction, the diffraction part's own albedo beside;
  refuse    a missing or corrupt table, a parameter out of domain, a texture with a material folder: one line each.

Each test prints its measured figures (`pytest -rP` shows them).
"""
import math
import shutil
import tempfile
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
import twoscale_mitsuba  # noqa: F401  (registers the plugin for every spectral variant)
from checks import params_of, random_pairs, report
from test_bsdf import bsdf_dict, chi2_bsdf, make_si, refusal, vec3

# Across the domain: without diffraction (chi2: beta 0.3, p 0.3; chi4: beta 0.03, p 0.8) and with it (chi6: 0.1, 0.9;
# chi7: 0.03, 1, b 5, c 1.5; chi9: 0.05, 3, broad, c 1.05; chi12: 0.4, 4; furnace6: 0.005, 1, b 16, narrow).
MATERIALS = ["chi2", "chi4", "chi6", "chi7", "chi9", "chi12", "furnace6"]
PARAMS = ("beta", "p", "sigma_s", "b", "c")


def general_dict(tables, m, **kw):
    """The general-mode BSDF of a material folder's parameters (b and c of a non-diffracting one: any in the domain)."""
    d = {"type": "twoscale", "tables": str(tables), "fresnel": "one", "beta": m["beta"], "p": m["p"],
         "sigma_s": m.get("sigma_s") or 0.0, "b": m.get("b") or 1.0, "c": m.get("c") or 2.0}
    d.update(kw)
    return d


def wavelengths(m, rng, n):
    lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.36, 0.83)
    return rng.uniform(lo, hi, n) * 1e3


def rho(bsdf, wi, wo, lam):
    """eval() / cos theta_o at arrays of (wi, wo, lambda nm), as float64."""
    si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi))
    return np.asarray(bsdf.eval(mi.BSDFContext(), si, vec3(wo))[0], dtype=np.float64) / wo[:, 2]


# -- agreement with the per-material BSDF ---------------------------------------------------------
@pytest.mark.parametrize("lobe", ["exact", "fit"])
def test_general_agrees_with_material_folders(variant_llvm_ad_spectral, materials, tables, lobe):
    rng = np.random.default_rng(61)
    rows = []
    for name in MATERIALS:
        m = params_of(materials / name)
        wi, wo = random_pairs(rng, m["beta"], 1500, 500)
        wi, wo = (x.astype(np.float32).astype(np.float64) for x in (wi, wo))
        lam = wavelengths(m, rng, len(wi))
        want = rho(mi.load_dict(bsdf_dict(materials / name, lobe=lobe)), wi, wo, lam)
        got = rho(mi.load_dict(general_dict(tables, m, lobe=lobe)), wi, wo, lam)
        keep = want >= 1e-3 * want.max()
        rel = np.abs(got[keep] - want[keep]) / want[keep]
        rows.append((name, np.median(rel), np.percentile(rel, 99), rel.max(), keep.sum()))
    for name, med, p99, mx, n in rows:
        print(f"      agree ({lobe}): {name} {n} points: median {med:.2e}, 99th percentile {p99:.2e}, max {mx:.2e}")
    worst_med, worst_p99 = max(r[1] for r in rows), max(r[2] for r in rows)
    # Both lobes to issue 60's bar. lobe = "fit" meets it because zh_convolution stores ln s_cos (0.13.0): with s_cos
    # interpolated itself between the beta nodes the fit lobe missed it (median 1.6e-3, p99 2.7e-2 at chi6).
    tol_med, tol_p99 = 1e-3, 1e-2
    report(worst_med <= tol_med and worst_p99 <= tol_p99, f"agree ({lobe}): general mode against the per-material BSDF at "
           f"{len(rows)} materials, 2,000 random (wi, wo, lambda) each where rho >= 1e-3 of its largest: worst median "
           f"{worst_med:.2e} (tol {tol_med:g}), worst 99th percentile {worst_p99:.2e} (tol {tol_p99:g})")


# -- textures ---------------------------------------------------------------------------------------
def test_general_bitmap_texels(variant_llvm_ad_spectral, tables):
    """Each parameter a 4 x 4 nearest-filtered bitmap of random values; at each texel's centre eval() equals the
    float BSDF of that texel's values (the same kernel arithmetic: <= 1e-6 relative)."""
    rng = np.random.default_rng(7)
    n = 4
    maps = {"beta": np.exp(rng.uniform(math.log(0.01), math.log(0.4), (n, n))), "p": rng.uniform(0.3, 3.0, (n, n)),
            "sigma_s": rng.uniform(0.0, 0.08, (n, n)), "b": rng.uniform(0.3, 8.0, (n, n)), "c": rng.uniform(1.1, 3.0, (n, n))}
    maps["sigma_s"][0, :2] = 0.0  # plain EPD texels
    textured = mi.load_dict({"type": "twoscale", "tables": str(tables), "fresnel": "one",
                             **{k: {"type": "bitmap", "bitmap": mi.Bitmap(v.astype(np.float32)[..., None]), "raw": True,
                                    "filter_type": "nearest"} for k, v in maps.items()}})
    worst = 0.0
    wi, wo = random_pairs(rng, 0.2, 48, 16)
    lam = rng.uniform(360, 830, len(wi))
    for row in range(n):
        for col in range(n):
            values = {k: float(np.float32(v[row, col])) for k, v in maps.items()}
            si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi))
            si.uv = mi.Point2f((col + 0.5) / n, (row + 0.5) / n)
            got = np.asarray(textured.eval(mi.BSDFContext(), si, vec3(wo))[0], dtype=np.float64)
            want = rho(mi.load_dict({"type": "twoscale", "tables": str(tables), "fresnel": "one", **values}), wi, wo, lam) * wo[:, 2]
            rel = np.abs(got - want) / np.maximum(np.abs(want), 1e-30)
            worst = max(worst, float(rel[want > 0].max()))
            assert np.all((want > 0) == (got > 0))
    report(worst <= 1e-6, f"texture: 5 nearest-filtered 4 x 4 bitmaps (two texels with sigma_s = 0): eval() at each texel's "
           f"centre against the float BSDF of its values, {n * n} texels x {len(wi)} pairs: max rel. diff {worst:.2e} (tol 1e-6)")


# -- chi-square -------------------------------------------------------------------------------------
# energy = "compensated" adds the cosine strategy (epd_albedo's E_c): without diffraction, and two with it.
CHI2_CASES = [(name, theta, "single") for name in MATERIALS for theta in (30, 75)]
CHI2_CASES += [(name, theta, "compensated") for name in ("chi2", "chi6", "chi12") for theta in (30, 75)]


@pytest.mark.parametrize("name, theta, energy", CHI2_CASES)
def test_general_chi2(variant_llvm_ad_spectral, materials, tables, name, theta, energy):
    m = params_of(materials / name)
    lam = 550.0 if not m.get("sigma_s") else 1e3 * 0.5 * (m["wavelength_min"] + m["wavelength_max"])
    ok, p, msg = chi2_bsdf(mi.load_dict(general_dict(tables, m, energy=energy)), theta, lam, m["beta"])
    report(ok, f"chi2 (general): {name} {energy} theta_i={theta} lambda={lam:.0f}: p-value {p:.3g}" + ("" if ok else "\n" + msg))


# -- gradients ---------------------------------------------------------------------------------------
def forward_grad(bsdf, key, si, wo):
    """d eval / d parameter (mi.traverse key) by forward-mode AD, per lane."""
    params = mi.traverse(bsdf)
    x = type(params[key])(params[key])
    dr.enable_grad(x)
    params[key] = x
    params.update()
    out = bsdf.eval(mi.BSDFContext(), si, wo)[0]
    dr.forward(x)
    grad = np.asarray(dr.grad(out), dtype=np.float64)
    dr.disable_grad(x)
    return grad


@pytest.mark.parametrize("name", ["chi6", "chi12"])
def test_general_gradients(variant_llvm_ad_spectral, materials, tables, name):
    """d eval / d (beta, p, sigma_s, b, c) by forward-mode AD against central differences of eval, within 2 % where
    the gradient is not tiny: |d ln eval / d ln x| >= 0.05 (float32's eval moves by about 1e-6 of its value, so a
    central difference with h = 1e-3 x is good to 2 % there; the tables are read multilinearly, so a wider step could
    straddle a node, where the interpolant's slope jumps)."""
    m = params_of(materials / name)
    rng = np.random.default_rng(17)
    wi, wo = random_pairs(rng, m["beta"], 48, 0)
    si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], 550.0, len(wi))
    wo_v = vec3(wo)
    bsdf = mi.load_dict(general_dict(tables, m))
    params = mi.traverse(bsdf)
    for p in PARAMS:
        key = f"{p}.value"
        x0 = float(np.ravel(params[key])[0])
        ad = forward_grad(bsdf, key, si, wo_v)
        value = np.asarray(bsdf.eval(mi.BSDFContext(), si, wo_v)[0], dtype=np.float64)
        h = 1e-3 * x0
        vals = []
        for x in (x0 + h, x0 - h):
            params[key] = dr.opaque(type(params[key]), x)
            params.update()
            vals.append(np.asarray(bsdf.eval(mi.BSDFContext(), si, wo_v)[0], dtype=np.float64))
        params[key] = dr.opaque(type(params[key]), x0)
        params.update()
        fd = (vals[0] - vals[1]) / (2 * h)
        big = np.abs(ad) * x0 >= 0.05 * np.abs(value)
        rel = np.abs(ad[big] - fd[big]) / np.abs(fd[big])
        report(big.sum() > 0 and rel.max() <= 0.02, f"grad (general): {name} d eval/d {p} at {x0:g}, {big.sum()} of {len(wi)} "
               f"pairs: forward AD against central differences max rel. diff {rel.max():.2e}, median {np.median(rel):.2e} (tol 2 %)")


def test_general_texel_gradient(variant_llvm_ad_spectral, tables):
    """A bitmap's texel gets the gradient its float would: d eval / d texel = d eval / d beta at the texel's uv."""
    m = {"beta": 0.08, "p": 1.2, "sigma_s": 0.03, "b": 1.5, "c": 2.2}
    grid = np.array([[0.08, 0.2], [0.3, 0.05]], dtype=np.float32)[..., None]
    textured = mi.load_dict(general_dict(tables, m, beta={"type": "bitmap", "bitmap": mi.Bitmap(grid), "raw": True,
                                                          "filter_type": "nearest"}))
    plain = mi.load_dict(general_dict(tables, m))
    rng = np.random.default_rng(23)
    wi, wo = random_pairs(rng, 0.08, 32, 0)
    si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], 550.0, len(wi))
    si.uv = mi.Point2f(0.25, 0.25)  # texel (0, 0)
    want = forward_grad(plain, "beta.value", si, vec3(wo))
    params = mi.traverse(textured)
    data = mi.TensorXf(params["beta.data"])
    dr.enable_grad(data)
    params["beta.data"] = data
    params.update()
    out = textured.eval(mi.BSDFContext(), si, vec3(wo))[0]
    dr.backward(dr.sum(out))
    got = np.asarray(dr.grad(data)).ravel()
    report(abs(got[0] - want.sum()) <= 1e-5 * abs(want.sum()) and np.all(got[1:] == 0),
           f"grad (general): d sum(eval)/d texel (0, 0) of a beta bitmap {got[0]:.6g} against d/d beta of the float "
           f"{want.sum():.6g}; the other texels {got[1:]} (none read)")


# -- energy compensation ------------------------------------------------------------------------------
def test_general_furnace(variant_llvm_ad_spectral, tables):
    """energy = "compensated", F = 1: the Monte Carlo albedo over a grid of the domain. Without diffraction the
    multiple-scattering lobe from epd_albedo restores 1; with it, the diffraction part keeps its own albedo (the
    general tables hold no renormalisation g: docs/runtimes.md "General mode"), reported beside."""
    from test_bsdf import albedo

    plain, diffracting = [], []
    for beta in (0.01, 0.1, 0.4):
        for p in (0.3, 1.0, 3.0):
            for sigma_s, out in ((0.0, plain), (0.05, diffracting)):
                m = {"beta": beta, "p": p, "sigma_s": sigma_s, "b": 1.0, "c": 2.2}
                bsdf = mi.load_dict(general_dict(tables, m, energy="compensated"))
                for deg in (0, 45, 75, 85):
                    a, err = albedo(bsdf, deg, n=50_000)
                    out.append((abs(a - 1.0), a, err, beta, p, deg))
    worst = max(plain)
    spread = (min(x[1] for x in diffracting), max(x[1] for x in diffracting))
    print(f"      furnace (general, compensated): with sigma_s = 0.05 um, b 1 um, c 2.2 the albedo spans "
          f"{spread[0]:.4f} to {spread[1]:.4f} over the same grid")
    report(worst[0] <= 0.01 + 4 * worst[2], f"furnace (general, compensated): sigma_s = 0, beta 0.01-0.4, p 0.3-3, theta_i "
           f"0-85 deg: largest |albedo - 1| {worst[0]:.4f} +- {worst[2]:.4f} (beta {worst[3]}, p {worst[4]}, {worst[5]} deg; tol 0.01)")


# -- refusals -----------------------------------------------------------------------------------------
def test_general_refuses(variant_llvm_ad_spectral, materials, tables):
    m = {"beta": 0.08, "p": 1.2, "sigma_s": 0.02, "b": 1.5, "c": 2.2}
    cases = [(general_dict(tables, m, beta=0.7), "beta = 0.7 is outside the tables' domain [0.005, 0.5]"),
             (general_dict(tables, m, p=0.1), "p = 0.1 is outside the tables' domain [0.2, 5]"),
             (general_dict(tables, m, b=50.0), "b = 50 is outside the tables' domain"),
             (general_dict(tables, m, sigma_s=-0.01), "sigma_s = -0.01 is outside the tables' domain"),
             (general_dict(tables, m, c={"type": "bitmap", "bitmap": mi.Bitmap(np.full((2, 2, 1), 3.5, np.float32)), "raw": True}),
              "c's bitmap holds 3.5 to 3.5, outside the tables' domain [1.02, 3.02]"),
             (general_dict(tables, m, beta={"type": "bitmap", "bitmap": mi.Bitmap(np.full((2, 2, 1), 0.1, np.float32))}),
              "beta's bitmap must be one channel, read raw"),
             ({k: v for k, v in general_dict(tables, m).items() if k != "c"}, "parameter 'c' is missing"),
             (bsdf_dict(materials / "chi6", beta={"type": "bitmap", "bitmap": mi.Bitmap(np.full((2, 2, 1), 0.1, np.float32)), "raw": True}),
              "beta is a texture, but")]
    for d, needle in cases:
        msg = refusal(d)
        report(msg is not None and msg.startswith("TwoScaleError: ") and needle in msg, f"refuse (general): {msg}")
    # A float sigma_s = 0 is a plain EPD surface: p may go down to epd_g1's 0.05.
    report(refusal(general_dict(tables, m, sigma_s=0.0, p=0.1)) is None, "refuse (general): sigma_s = 0 with p = 0.1 loads")
    work = Path(tempfile.mkdtemp(prefix="twoscale-test-"))
    try:
        preset = work / "default"
        preset.mkdir()
        for f in tables.iterdir():
            if f.name.startswith(("epd_", "kcorr_", "zh_convolution")):
                shutil.copy(f, preset / f.name)
        msg = refusal(general_dict(preset, m))
        report(msg is not None and "table zh_lobe is missing" in msg, f"refuse (general): a missing table: {msg}")
        (preset / "zh_convolution.h5").write_bytes(b"\0" + (tables / "zh_convolution.h5").read_bytes()[1:])
        msg = refusal(general_dict(preset, m, lobe="fit"))
        report(msg is not None and "zh_convolution.h5" in msg and ("sha256" in msg.lower() or "checksum" in msg),
               f"refuse (general): a corrupt table: {msg}")
    finally:
        shutil.rmtree(work)
