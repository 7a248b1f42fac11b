"""Tests of the Mitsuba BSDF `twoscale` (the package twoscale_mitsuba) on the material folders of
runtimes/testing/test_materials.toml (fixtures: runtimes/conftest.py). `pytest runtimes/mitsuba`:

  lookup    Table.lookup_arrays equals Table.lookup at random points of every default-preset table;
  chi2      mitsuba.chi2 (sample() against pdf()) at the 13 parameter sets, 6 plastics and 6 subsurface materials, both energy modes;
  brute     eval() against reference.py (quadrature, no tables) at random (i, o, lambda, material),
            and against the numpy model on the general tables (twoscale_model.py, a second opinion);
  c         the C reference BRDF (twoscale_c.py) against this BSDF: eval, pdf and sample;
  furnace   white-furnace albedo (F = 1) over incidence; docs/maths.md section 7's limit 1 - A(theta_i);
  render    symbolic-mode and scalar renders are finite and non-negative; the variants agree (both energy modes);
  grad      gradients of a render by dr.backward against central finite differences (both energy modes);
  corrupt   a corrupt folder or bundle, or a parameter that differs from the tables, is one clear error;
  energy    energy = "compensated": white furnace 1 within 1 % over incidence and wavelength, reciprocity,
            no energy created with a conductor.

Each test prints its measured figures (`pytest -rP` shows them).
"""
import hashlib
import math
import shutil
import tarfile
import tempfile
import time
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
import reference
import twoscale_mitsuba  # noqa: F401  (registers the plugin for every spectral variant)
from checks import (
    CHI2_CASES,
    ENERGY_ANGLES,
    ENERGY_MATERIALS,
    PLASTIC_CHI2_CASES,
    SUBSURFACE_CHI2_CASES,
    HalfVectorRule,
    chi2_run,
    energy_wavelengths,
    is_conductor,
    params_of,
    random_pair,
    random_pairs,
    report,
)
from twoscale_tables import Table

DEFAULT_TABLES = ["epd_albedo", "epd_albedo_avg", "epd_g1", "epd_norm", "epd_quantile", "kcorr_renorm", "zh_convolution", "zh_lobe"]


def bsdf_dict(folder, **kw):
    """F = 1 for a conductor (or what is not a material folder: a bundle) unless kw says otherwise; a plastic's F
    is its interface's."""
    d = {"type": "twoscale", "tables": str(folder)}
    if not (Path(folder) / "epd_g1.manifest.json").exists() or is_conductor(folder):
        d["fresnel"] = "one"
    d.update(kw)
    return d


def make_si(wi, lam_nm, n=1):
    """A SurfaceInteraction3f of n lanes at wi (a 3-list of floats or of arrays) and one wavelength (nm).
    A float becomes an opaque value: as a literal it would be compiled into the kernel, one kernel per
    angle and wavelength (Dr.Jit's JIT, ~2,000 kernels for these tests on a fresh machine)."""
    def value(c):
        return mi.Float(np.asarray(c, dtype=np.float32)) if np.ndim(c) else dr.opaque(mi.Float, float(c))
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[value(c) for c in wi])
    si.wavelengths = mi.Spectrum(value(lam_nm))
    return si


def vec3(a):
    a = np.asarray(a, dtype=np.float32)
    return mi.Vector3f(mi.Float(a[:, 0]), mi.Float(a[:, 1]), mi.Float(a[:, 2]))


# -- lookup -----------------------------------------------------------------------
@pytest.mark.parametrize("name", DEFAULT_TABLES)
def test_lookup(tables, name):
    rng = np.random.default_rng(5)
    for h5 in [tables / f"{name}.h5"]:
        t = Table.open(h5)
        # Physical coordinates: an axis's node range, or a derived axis's coordinate range.
        derived = {d["axis"]: d for d in t.manifest.get("derived_axes", [])}
        pts = {}
        for a, nodes, name in zip(t.manifest["axes"], t.axes, t.coordinates()):
            d = derived.get(a["name"])
            fin = np.array([d["min"], d["max"]]) if d else nodes[np.isfinite(nodes)]
            x = rng.uniform(fin.min(), fin.max(), 200)
            x[:3] = [d["min"], d["max"], 0.5 * (d["min"] + d["max"])] if d else nodes[[0, -1, len(nodes) // 2]]
            pts[name] = x
        vec = t.lookup_arrays(pts)
        same = all(t.lookup({k: pts[k][i] for k in pts})[v] == vec[v][i] for i in range(200) for v in vec)
        report(same, f"lookup: {h5.stem}: lookup_arrays == lookup at 200 points (bit for bit)")
        with pytest.raises(ValueError, match="outside"):
            t.lookup_arrays({k: np.append(v[:2], np.nan) for k, v in pts.items()})


# -- chi2 -------------------------------------------------------------------------
@pytest.mark.parametrize("energy", ["single", "compensated"])
@pytest.mark.parametrize("name, theta, lam", CHI2_CASES + PLASTIC_CHI2_CASES + SUBSURFACE_CHI2_CASES)
def test_chi2(variant_llvm_ad_spectral, materials, name, theta, lam, energy):
    bsdf = mi.load_dict(bsdf_dict(materials / name, energy=energy))
    t0 = time.time()
    ok, p, msg = chi2_bsdf(bsdf, theta, lam, params_of(materials / name)["beta"])
    report(ok, f"chi2: {name} {material_text(materials / name)} {energy} theta_i={theta} lambda={lam}: p-value {p:.3g} "
              f"({time.time() - t0:.1f} s)" + ("" if ok else "\n" + msg))


def chi2_bsdf(bsdf, theta, lam, beta):
    """chi2_run on a BSDF's sample() and pdf() at theta_i (degrees) and one wavelength (nm)."""
    th = math.radians(theta)
    wi = [math.sin(th), 0.0, math.cos(th)]
    ctx = mi.BSDFContext()

    def sample(s):
        bs, _ = bsdf.sample(ctx, make_si(wi, lam, dr.width(s)), s[0], mi.Point2f(s[1], s[2]))
        return bs.wo, dr.select(bs.pdf > 0, mi.Float(1.0), mi.Float(0.0))

    def pdf(wo):
        return bsdf.pdf(ctx, make_si(wi, lam, dr.width(wo)), wo)

    return chi2_run(sample, pdf, beta, theta)


def material_text(folder):
    m = params_of(folder)
    return "(" + ", ".join(f"{k} {m[k]:g}" for k in ("beta", "p", "sigma_s", "b", "c") if m.get(k)) + ")"


# -- brute force --------------------------------------------------------------------
def brute_points(materials, count, seed=29):
    """count random (material, wi, wo, lambda nm, eta, k) over the folders of MATERIALS."""
    rng = np.random.default_rng(seed)
    folders = sorted(d for d in materials.iterdir() if (d / "epd_g1.h5").exists() and is_conductor(d))
    pts = []
    for _ in range(count):
        folder = folders[rng.integers(len(folders))]
        m = params_of(folder)
        lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.38, 0.78)
        wi, wo = random_pair(rng, m["beta"])
        pts.append((folder, wi, wo, rng.uniform(lo, hi) * 1e3, rng.uniform(0.2, 2.5), rng.uniform(1.0, 5.0)))
    return pts


def parts_at(bsdf, wi, wo, lam):
    """(specular, diffraction) of rho / F at arrays of (wi, wo, lambda nm) through the BSDF's eval_parts."""
    si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi))
    spec, diff = bsdf.eval_parts(si, vec3(wo))
    return np.asarray(spec, dtype=np.float64), np.asarray(diff, dtype=np.float64)


def test_brute(variant_llvm_ad_spectral, materials, tables, count=240):
    from twoscale_model import TwoScaleModel, open_tables

    pts = brute_points(materials, count)
    cache, spec_errs, lobe_errs, peak_errs, fit_errs, total_errs, model_spec, model_lobe = {}, [], [], [], [], [], [], []
    worst = {}
    general = open_tables(tables, ["epd_g1", "epd_norm", "kcorr_renorm", "zh_convolution", "zh_lobe"])
    t0 = time.time()
    for folder, wi, wo, lam, eta, k in pts:
        if folder not in cache:
            cache[folder] = {lobe: mi.load_dict(bsdf_dict(folder, lobe=lobe)) for lobe in ("exact", "fit")}
        m = params_of(folder)
        sigma_s = m.get("sigma_s") or 0.0
        spec_r, diff_r, peak, f = reference.brdf(wi, wo, lam * 1e-3, m["beta"], m["p"], sigma_s, m.get("b") or 1.0,
                                                 m.get("c") or 2.0, eta, k)
        spec_t, diff_t = (x[0] for x in parts_at(cache[folder]["exact"], wi[None], wo[None], lam))
        conductor = mi.load_dict(bsdf_dict(folder, fresnel="conductor", eta=eta, k=k)) if len(total_errs) < 60 else None
        if conductor is not None:  # eval() = F (specular + diffraction) cos theta_o, F in complex arithmetic (first 60 points)
            si = make_si(list(map(float, wi)), lam)
            got = np.asarray(conductor.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo))), dtype=np.float64)[0, 0]
            want = f * (spec_t + diff_t)  # 0 where D and C underflow float32: then eval must be 0 too
            total_errs.append(abs(got / wo[2] - want) / want if want > 0 else abs(got))
        # Relative where the specular part is at least 1e-6 of its value at h = n (deeper in the tails, D
        # falls below float32's reach): what the tables' accuracy is measured on.
        cos_h = ((wi + wo) / np.linalg.norm(wi + wo))[2]
        in_reach = reference.ndf(cos_h, m["beta"], m["p"]) >= 1e-6 * reference.ndf(1.0, m["beta"], m["p"])
        if in_reach:
            e = abs(spec_t - spec_r) / spec_r
            spec_errs.append(e)
            worst["spec"] = max(worst.get("spec", (0, None)), (e, (folder.name, wi, wo, lam)), key=lambda x: x[0])
        if sigma_s > 0:
            e = abs(diff_t - diff_r) / diff_r
            lobe_errs.append(e)
            peak_errs.append(abs(diff_t - diff_r) / peak)
            worst["lobe"] = max(worst.get("lobe", (0, None)), (e, (folder.name, wi, wo, lam)), key=lambda x: x[0])
            if m["beta"] <= (0.35 if m["p"] >= 1 else 0.2):  # where C peaks at theta_h = 0, the shape the fit assumes
                _, diff_fit = (x[0] for x in parts_at(cache[folder]["fit"], wi[None], wo[None], lam))
                fit_errs.append(abs(diff_fit - diff_r) / peak)
        # The numpy model on the general tables: a second opinion.
        model = TwoScaleModel(general, m["beta"], m["p"], sigma_s, m.get("b") or 1.0, m.get("c") or 2.0, lobe="exact")
        ms, md = model.eval_parts(wi[None], wo[None], lam * 1e-3)
        if in_reach:
            model_spec.append(abs(ms[0] - spec_t) / spec_t)
        if sigma_s > 0 and m["beta"] <= (0.35 if m["p"] >= 1 else 0.2):
            model_lobe.append(abs(md[0] - diff_t) / peak)
    n_lobe = len(lobe_errs)
    print(f"      brute: {len(pts)} points over {len(cache)} materials ({n_lobe} with diffraction) in {time.time() - t0:.1f} s", flush=True)
    report(max(total_errs) < 1e-5, f"brute: eval() = F (specular + diffraction) cos theta_o, F of a random conductor "
          f"index from reference.py (complex arithmetic): max rel. diff {max(total_errs):.2e} at {len(total_errs)} points (tol 1e-5)")
    report(max(spec_errs) < 1e-3, f"brute: specular part against reference.py: max rel. diff {max(spec_errs):.2e}, median "
          f"{np.median(spec_errs):.2e} (tol 1e-3) at {len(spec_errs)} points where it is >= 1e-6 of its value at h = n, "
          f"worst at {fmt(worst['spec'][1])}")
    report(max(lobe_errs) < 3e-3, f"brute: diffraction part (lobe = \"exact\") against reference.py: max rel. diff "
          f"{max(lobe_errs):.2e}, median {np.median(lobe_errs):.2e}, 99th percentile {np.percentile(lobe_errs, 99):.2e} "
          f"(tol 3e-3) at {fmt(worst['lobe'][1])}; relative to the lobe's peak max {max(peak_errs):.2e}")
    report(max(fit_errs) < 0.3, f"brute: diffraction part (lobe = \"fit\", the paper's fitted lobe) against reference.py: "
          f"|diff| / lobe peak median {np.median(fit_errs):.3g}, max {max(fit_errs):.3g} at {len(fit_errs)} points of materials "
          f"with beta <= 0.2 (p < 1) or 0.35 (tol 0.3, the fit's own error)")
    report(max(model_spec) < 1e-3 and np.percentile(model_lobe, 99) < 0.05,
           f"brute: the numpy model on the general tables agrees: specular max rel. diff {max(model_spec):.2e} (tol 1e-3), "
           f"diffraction (where C peaks at theta_h = 0) |diff| / lobe peak median {np.median(model_lobe):.2e}, 99th percentile "
           f"{np.percentile(model_lobe, 99):.2e} (tol 5e-2: the general zh_lobe's own error)")


# -- the C reference BRDF against this BSDF ------------------------------------------------
@pytest.mark.parametrize("energy", ["single", "compensated"])
def test_c(variant_llvm_ad_spectral, materials, c_cache, energy):
    """The C BRDF (runtimes/c/twoscale_brdf.h through twoscale_c.py) and this BSDF on the same
    float32 inputs: eval (random conductor index, both lobes) and pdf at the brute-force points, and
    sample() at the same two random numbers (both split xi1 by w_ms and w_d, docs/runtimes.md). Relative
    differences where D is within float32's reach (>= 1e-6 of its peak) and the value is not 0."""
    from twoscale_c import CBrdf

    rng = np.random.default_rng(31)
    worst = {"eval": 0.0, "pdf": 0.0, "wo": 0.0, "weight": 0.0}
    count = 0
    by_folder = {}
    for folder, wi, wo, lam, eta, k in brute_points(materials, 240, seed=43):
        by_folder.setdefault(folder, []).append((wi, wo, lam, eta, k))
    t0 = time.time()
    for folder, pts in by_folder.items():
        m = params_of(folder)
        wi = np.array([p[0] for p in pts], dtype=np.float32).astype(np.float64)
        wo = np.array([p[1] for p in pts], dtype=np.float32).astype(np.float64)
        lam = np.array([p[2] for p in pts], dtype=np.float32).astype(np.float64)
        eta, k = float(np.float32(pts[0][3])), float(np.float32(pts[0][4]))  # one conductor per material
        h = (wi + wo) / np.linalg.norm(wi + wo, axis=1)[:, None]
        tan2 = (1 - h[:, 2] ** 2) / h[:, 2] ** 2
        reach = (tan2 / m["beta"] ** 2) ** m["p"] < math.log(1e6)
        wi, wo, lam = wi[reach], wo[reach], lam[reach]
        for lobe in ("exact", "fit") if m.get("sigma_s") else ("exact",):
            c = CBrdf(folder, lobe=lobe, cache_dir=c_cache, energy=energy)
            got_c = c.eval(wi, wo, lam * 1e-3, eta=np.full(len(wi), eta), k=np.full(len(wi), k))
            pdf_c = c.pdf(wi, wo, lam * 1e-3)
            b = mi.load_dict(bsdf_dict(folder, lobe=lobe, fresnel="conductor", eta=eta, k=k, energy=energy))
            si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi))
            v, pdf = b.eval_pdf(mi.BSDFContext(), si, vec3(wo))
            v = np.asarray(v[0], dtype=np.float64) / wo[:, 2]
            pdf = np.asarray(pdf, dtype=np.float64)
            worst["eval"] = max(worst["eval"], float((np.abs(v - got_c) / got_c).max(initial=0.0)))
            worst["pdf"] = max(worst["pdf"], float((np.abs(pdf - pdf_c) / pdf_c).max(initial=0.0)))
            count += len(wi)
        # sample(): the same (xi1, xi2) at 64 incidences, F = 1.
        n = 64
        ti = np.arccos(rng.uniform(0.05, 1.0, n))
        wi_s = np.stack([np.sin(ti), 0 * ti, np.cos(ti)], 1).astype(np.float32).astype(np.float64)
        xi1, xi2 = (rng.random(n).astype(np.float32).astype(np.float64) for _ in range(2))
        lam0 = np.float32(0.55) if m.get("wavelength_min") is None else np.float32(0.5 * (m["wavelength_min"] + m["wavelength_max"]))
        wo_c, pdf_c, w_c = CBrdf(folder, cache_dir=c_cache, energy=energy).sample(wi_s, np.full(n, float(lam0)), xi1, xi2)
        b = mi.load_dict(bsdf_dict(folder, energy=energy))
        si = make_si([wi_s[:, 0], wi_s[:, 1], wi_s[:, 2]], np.full(n, float(lam0) * 1e3), n)
        bs, w = b.sample(mi.BSDFContext(), si, mi.Float(0.5), mi.Point2f(mi.Float(xi1), mi.Float(xi2)))
        wo_m = np.stack([np.asarray(getattr(bs.wo, a), dtype=np.float64) for a in "xyz"], 1)
        w_m = np.asarray(w[0], dtype=np.float64)
        ok = (pdf_c > 0) & (np.asarray(bs.pdf) > 0) & (w_c > 0)
        worst["wo"] = max(worst["wo"], float(np.abs(wo_m - wo_c)[ok].max(initial=0.0)))
        rel_w = float((np.abs(w_m - w_c)[ok] / w_c[ok]).max(initial=0.0))
        if rel_w > worst["weight"]:
            worst["weight"], worst["weight_at"] = rel_w, folder.name
    print(f"      c ({energy}): {count} (point, lobe) pairs over {len(by_folder)} materials in {time.time() - t0:.1f} s", flush=True)
    # pdf: a float32 theta_h next to a quantile node can fall in the neighbouring cell, whose density
    # differs by its slope (about 1e-4 relative): the tolerance is that; compensated, the cosine
    # strategy's share comes from a float32 texture as well (twice that).
    pdf_tol = 1e-4 if energy == "single" else 2e-4
    report(worst["eval"] < 1e-5 and worst["pdf"] < pdf_tol, f"c: the C BRDF and this BSDF agree ({energy}): eval (conductor, both lobes) "
          f"max rel. diff {worst['eval']:.2e} (tol 1e-5), pdf {worst['pdf']:.2e} (tol {pdf_tol:g}) at {count} points")
    # Compensated, cosine samples land anywhere, also on the steep flanks of narrow lobes, where a float32
    # direction moves rho by more.
    w_tol = 1e-3 if energy == "single" else 5e-3
    report(worst["wo"] < 1e-4 and worst["weight"] < w_tol, f"c: sample() at the same two numbers ({energy}): max |wo_C - wo_Mitsuba| "
          f"{worst['wo']:.2e} (tol 1e-4), weight max rel. diff {worst['weight']:.2e} at {worst.get('weight_at')} (tol {w_tol:g}; float32 directions)")


# -- white furnace -------------------------------------------------------------------
FURNACE = ["furnace1", "furnace2", "furnace3", "furnace4", "furnace5", "furnace6"]
FURNACE_ANGLES = [0, 30, 60, 75, 85, 89]
LIMIT = "furnace6"  # beta -> 0, B = 29 at 550 nm: docs/maths.md section 7's limit


def albedo(bsdf, theta_deg, n=100_000, lam=550.0, seed=3):
    """Monte Carlo albedo (mean of sample()'s weights at F = 1) and its standard error."""
    th = math.radians(theta_deg)
    si = make_si([math.sin(th), 0.0, math.cos(th)], lam, n)
    rng = np.random.default_rng(seed)
    s = [mi.Float(rng.random(n).astype(np.float32)) for _ in range(3)]
    _, w = bsdf.sample(mi.BSDFContext(), si, s[0], mi.Point2f(s[1], s[2]))
    w = np.asarray(w[0], dtype=np.float64)
    return w.mean(), w.std() / math.sqrt(n)


def limit_quadrature(n=400):
    """theta_h nodes at normal incidence (theta_d = theta_h, theta_o = 2 theta_h, do = 4 cos theta_h dh),
    the outgoing directions and the quadrature weights of int ... cos theta_o do."""
    x = np.concatenate([[0.0], np.geomspace(1e-4, math.pi / 4, n)])
    th, dth = 0.5 * (x[1:] + x[:-1]), np.diff(x)
    o = np.stack([np.sin(2 * th), 0 * th, np.cos(2 * th)], 1)
    return th, o, 4.0 * np.cos(th) * 2.0 * math.pi * np.sin(th) * dth * o[:, 2]


def test_furnace(variant_llvm_ad_spectral, materials):
    worst = (0.0, None)
    for name in FURNACE:
        m = params_of(materials / name)
        for lobe in ("exact", "fit") if m.get("sigma_s") else ("exact",):
            bsdf = mi.load_dict(bsdf_dict(materials / name, lobe=lobe))
            row = []
            for deg in FURNACE_ANGLES:
                a, err = albedo(bsdf, deg)
                row.append(f"{deg}: {a:.4f}")
                if not m.get("sigma_s"):
                    # Single scattering with height-correlated Smith G2 <= G1(i) loses energy, never gains it.
                    report(a <= 1.0 + 4 * err, f"furnace: {name} theta_i={deg}: albedo {a:.4f} +- {err:.4f} <= 1")
                if a - 1.0 > worst[0]:
                    worst = (a - 1.0, (name, lobe, deg))
            print(f"      furnace {name} {material_text(materials / name)} ({lobe}): albedo by theta_i: {', '.join(row)}", flush=True)
    report(worst[0] < 0.25, f"furnace: largest departure above 1: {worst[0]:.4f} at {worst[1]} (bound 0.25)")
    # docs/maths.md section 7's limit: beta -> 0, narrow lobe, F = 1: the diffraction part's albedo -> 1 - A(theta_i).
    m, lam = params_of(materials / LIMIT), 0.55
    one_minus_a = -math.expm1(-((4 * math.pi * m["sigma_s"] / lam) ** 2))
    th, o, w = limit_quadrature()
    bb, r = m["b"] / lam, reference.renorm(0.0, m["b"] / lam, m["c"])
    g1i = reference.g1(m["p"], 1.0, m["beta"])
    brute = 0.0
    for t, oz, wj in zip(th, o[:, 2], w):
        a = math.exp(-((4 * math.pi * m["sigma_s"] * math.cos(t) / lam) ** 2))
        g2 = 1.0 / (1.0 / g1i + 1.0 / reference.g1(m["p"], oz, m["beta"]) - 1.0)
        c = reference.lobe_c(t, bb * math.cos(t), m["c"], m["p"], m["beta"])
        brute += (1 - a) * g2 * (m["c"] - 1) * bb * bb / (2 * math.pi * r) * reference.norm_p(m["p"]) / m["beta"] ** 2 * c * wj
    report(abs(brute / one_minus_a - 1) < 0.02, f"furnace: docs/maths.md section 7 limit ({LIMIT}) with the reference C: "
          f"diffraction albedo {brute:.4f} vs 1 - A = {one_minus_a:.4f} ({brute / one_minus_a - 1:+.2%}, tol 2 %)")
    for lobe, tol in (("exact", 0.03), ("fit", 0.15)):  # the fitted lobe overshoots C's tails
        bsdf = mi.load_dict(bsdf_dict(materials / LIMIT, lobe=lobe))
        _, diff = parts_at(bsdf, np.repeat([[0.0, 0.0, 1.0]], len(th), 0), o, 550.0)
        got = float((diff * w).sum())
        report(abs(got / one_minus_a - 1) < tol, f"furnace: docs/maths.md section 7 limit, lobe {lobe}: diffraction albedo "
              f"{got:.4f} vs 1 - A = {one_minus_a:.4f} ({got / one_minus_a - 1:+.2%}, tol {tol:.0%}; reference C {brute:.4f})")


# -- energy ----------------------------------------------------------------------------
CONDUCTORS = [(0.2, 3.4), (1.5, 0.3), (1.0, 0.05)]  # gold-like, weakly absorbing, nearly index-matched


def hemisphere_albedo(rule, bsdf, theta_deg, lam_nm):
    """int eval(i, o) do (eval is rho cos theta_o) at theta_i, one wavelength, by the half-vector rule."""
    i, o, w = rule.nodes(theta_deg)
    f = np.asarray(bsdf.eval(mi.BSDFContext(), make_si(list(i), lam_nm, len(o)), vec3(o))[0], dtype=np.float64)
    return float((f * w).sum())


def test_energy_furnace(variant_llvm_ad_spectral, materials):
    """energy = "compensated": the white furnace by the half-vector rule, and sample()'s mean weight."""
    rule = HalfVectorRule()
    worst = {"single": (0.0, None), "compensated": (0.0, None)}
    for name in ENERGY_MATERIALS:
        m = params_of(materials / name)
        single = mi.load_dict(bsdf_dict(materials / name))
        comp = mi.load_dict(bsdf_dict(materials / name, energy="compensated"))
        for lam in energy_wavelengths(m):
            rows = {"single": [], "compensated": []}
            for deg in ENERGY_ANGLES:
                for mode, bsdf in (("single", single), ("compensated", comp)):
                    e = hemisphere_albedo(rule, bsdf, deg, lam)
                    rows[mode].append(e)
                    if abs(e - 1) > worst[mode][0]:
                        worst[mode] = (abs(e - 1), (name, deg, round(lam)))
            print(f"      energy {name} {material_text(materials / name)} lambda={lam:.0f}: albedo by theta_i "
                  f"{ENERGY_ANGLES}: single {' '.join(f'{e:.4f}' for e in rows['single'])}; "
                  f"compensated {' '.join(f'{e:.4f}' for e in rows['compensated'])}", flush=True)
        # Monte Carlo through sample(): an estimate independent of the quadrature
        a, err = albedo(comp, 60, lam=550.0 if not m.get("sigma_s") else energy_wavelengths(m)[1])
        report(abs(a - 1) < 0.01 + 4 * err, f"energy: {name} compensated, sample()'s mean weight at 60 deg: {a:.4f} +- {err:.4f} (1 within 1 %)")
    report(worst["compensated"][0] < 0.01, f"energy: compensated furnace within 1 % of 1 at {len(ENERGY_MATERIALS)} materials x "
          f"{len(ENERGY_ANGLES)} angles (0-89 deg) x 3 wavelengths: largest departure {worst['compensated'][0]:.4f} at "
          f"{worst['compensated'][1]} (single: {worst['single'][0]:.4f} at {worst['single'][1]})")


def test_energy_conductor(variant_llvm_ad_spectral, materials):
    """With a conductor: F <= 1 and F_avg's factor <= 1, so no energy is created."""
    rule = HalfVectorRule()
    most = (0.0, None)
    for name in ENERGY_MATERIALS:
        for eta, k in CONDUCTORS:
            bsdf = mi.load_dict(bsdf_dict(materials / name, energy="compensated", fresnel="conductor", eta=eta, k=k))
            for deg in (0, 60, 85, 89):
                e = hemisphere_albedo(rule, bsdf, deg, energy_wavelengths(params_of(materials / name))[1])
                if e > most[0]:
                    most = (e, (name, eta, k, deg))
    report(most[0] <= 1.0 + 1e-3, f"energy: compensated with a conductor: largest albedo {most[0]:.4f} at {most[1]} (<= 1)")


def test_energy_reciprocity(variant_llvm_ad_spectral, materials):
    """Compensated, rho(i, o) = rho(o, i) (eval is rho cos theta_o)."""
    rng = np.random.default_rng(41)
    worst_r = (0.0, None)
    for name in ENERGY_MATERIALS:
        m = params_of(materials / name)
        for fresnel in ({"fresnel": "one"}, {"fresnel": "conductor", "eta": 0.2, "k": 3.4}):
            bsdf = mi.load_dict(bsdf_dict(materials / name, energy="compensated", **fresnel))
            wi, wo = random_pairs(rng, m["beta"], 500, 500)
            lam = rng.uniform(*energy_wavelengths(m)[::2], len(wi))
            ctx = mi.BSDFContext()
            f_io = np.asarray(bsdf.eval(ctx, make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi)), vec3(wo))[0]) / wo[:, 2]
            f_oi = np.asarray(bsdf.eval(ctx, make_si([wo[:, 0], wo[:, 1], wo[:, 2]], lam, len(wi)), vec3(wi))[0]) / wi[:, 2]
            big = np.maximum(f_io, f_oi)
            rel = np.abs(f_io - f_oi) / np.maximum(big, 1e-30)
            rel[big < 1e-6 * big.max()] = 0.0
            j = int(np.argmax(rel))
            if rel[j] >= worst_r[0]:
                worst_r = (float(rel[j]), (name, fresnel["fresnel"]))
    report(worst_r[0] <= 1e-6, f"energy: compensated rho(i, o) = rho(o, i) at 1000 pairs x {len(ENERGY_MATERIALS)} materials x 2 Fresnel: "
          f"largest relative difference {worst_r[0]:.2g} at {worst_r[1]} (tol 1e-6)")


# -- render ----------------------------------------------------------------------------
NICKEL_INDEX = {"eta": {"type": "spectrum", "value": [(400, 1.6), (700, 2.1)]},
                "k": {"type": "spectrum", "value": [(400, 2.6), (700, 3.9)]}}


def scene_dict(bsdf, res=32, spp=4, integrator=None):
    return {
        "type": "scene",
        "integrator": integrator or {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": 35,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "env": {"type": "constant", "radiance": 0.2},
        "light": {"type": "point", "position": [3, 3, 4], "intensity": 60.0},
    }


@pytest.mark.parametrize("energy", ["single", "compensated"])
def test_render(variant_llvm_ad_spectral, materials, energy):
    """A render in symbolic mode is finite, non-negative and not black, and evaluated mode renders the
    same image."""
    bsdf = bsdf_dict(materials / "rand1", fresnel="conductor", energy=energy, **NICKEL_INDEX)
    symbolic = dr.flag(dr.JitFlag.SymbolicLoops) and dr.flag(dr.JitFlag.SymbolicCalls)
    t0 = time.time()
    img = np.asarray(mi.render(mi.load_dict(scene_dict(bsdf))))
    report(symbolic and np.all(np.isfinite(img)) and img.min() >= 0 and img.max() > 0,
          f"render: {energy}: 32 x 32, 4 spp, llvm_ad_spectral, symbolic loops and calls: finite, non-negative, not black "
          f"(max {img.max():.3g}, {time.time() - t0:.1f} s)")
    dr.set_flag(dr.JitFlag.SymbolicLoops, False)
    dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    try:
        evaluated = np.asarray(mi.render(mi.load_dict(scene_dict(bsdf))))
    finally:
        dr.set_flag(dr.JitFlag.SymbolicLoops, True)
        dr.set_flag(dr.JitFlag.SymbolicCalls, True)
    report(np.allclose(evaluated, img, rtol=1e-4, atol=1e-6), f"render: {energy}: evaluated mode renders the same image as symbolic mode "
          f"(max |diff| {np.abs(evaluated - img).max():.2e})")


@pytest.mark.parametrize("energy", ["single", "compensated"])
def test_variants_agree(variants_all_spectral, materials, energy):
    """Every spectral variant gives the llvm_ad_spectral BSDF's eval and pdf (the scalar one calls the
    plugin one ray at a time), and renders a small image that is finite, non-negative and not black."""
    bsdf = bsdf_dict(materials / "rand1", fresnel="conductor", energy=energy, **NICKEL_INDEX)
    wi, wo = [0.3, 0.0, math.sqrt(0.91)], [-0.25, 0.1, math.sqrt(1 - 0.0725)]
    values = {}
    for variant in (variants_all_spectral, "llvm_ad_spectral"):
        mi.set_variant(variant)
        b = mi.load_dict(bsdf)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*wi)
        si.wavelengths = mi.Spectrum(420.0, 510.0, 600.0, 690.0)
        v, pdf = b.eval_pdf(mi.BSDFContext(), si, mi.Vector3f(*wo))
        values[variant] = np.append(np.ravel(np.asarray(v, dtype=np.float64)), float(np.ravel(np.asarray(pdf))[0]))
    mi.set_variant(variants_all_spectral)
    t0 = time.time()
    small = np.asarray(mi.render(mi.load_dict(scene_dict(bsdf, res=8, spp=2))))
    report(np.all(np.isfinite(small)) and small.min() >= 0 and small.max() > 0,
           f"render: {energy}: 8 x 8, 2 spp, {variants_all_spectral}: finite, non-negative, not black ({time.time() - t0:.1f} s)")
    mine, llvm = values[variants_all_spectral], values["llvm_ad_spectral"]
    report(np.allclose(mine, llvm, rtol=1e-5, atol=0), f"render: {energy}: eval and pdf agree between {variants_all_spectral} and "
           f"llvm_ad_spectral ({mine} vs {llvm})")


# -- gradients -------------------------------------------------------------------------
@pytest.mark.parametrize("energy", ["single", "compensated"])
def test_grad(variant_llvm_ad_spectral, materials, energy):
    """d(mean of a render)/d(parameter) by dr.backward against central finite differences of the same
    render. A point light and direct lighting only, so that the estimate is smooth in the parameters (no
    sampling decision depends on them). The adjoint pass draws its samples with seed_grad (8), so the
    finite differences render with that seed: both then sum the same paths. Both energy modes."""
    bsdf = bsdf_dict(materials / "chi6", fresnel="conductor", eta=1.6, k=3.0, energy=energy)
    d = scene_dict(bsdf, res=24, spp=4, integrator={"type": "prb", "max_depth": 2})
    del d["env"]
    scene = mi.load_dict(d)
    params = mi.traverse(scene)
    keys = {"sigma_s": "sphere.bsdf.sigma_s", "eta": "sphere.bsdf.eta.value", "k": "sphere.bsdf.k.value", "b": "sphere.bsdf.b"}
    base = {name: float(np.ravel(params[key])[0]) for name, key in keys.items()}

    def set_value(name, value):
        # Opaque, so that every finite-difference render runs the same kernel (a literal is compiled in).
        params[keys[name]] = dr.opaque(type(params[keys[name]]), value)
        params.update()

    def loss_at(name=None, value=None):
        if name is not None:
            set_value(name, value)
        out = float(np.ravel(dr.mean(mi.render(scene, params, seed=8), axis=None))[0])
        if name is not None:
            set_value(name, base[name])
        return out

    ad = adjoint(scene, params, keys.values())
    for name, key in keys.items():
        h = 1e-2 * base[name]
        fd = (loss_at(name, base[name] + h) - loss_at(name, base[name] - h)) / (2 * h)
        report(abs(ad[key] - fd) <= 0.02 * abs(fd) and fd != 0, f"grad: {energy}: d(mean image)/d {name} at {base[name]:g}: "
               f"dr.backward {ad[key]:.5g}, central difference (h = {h:.3g}) {fd:.5g} ({ad[key] / fd - 1:+.2%}, tol 2 %)")


def adjoint(scene, params, keys):
    """d(mean image)/d(params[key]) for every key, by one dr.backward of one render (seed 7, seed_grad 8) with the
    gradients of all of them enabled: one adjoint kernel rather than one per parameter."""
    keys = list(keys)
    for key in keys:
        dr.enable_grad(params[key])
    params.update()
    dr.backward(dr.mean(mi.render(scene, params, seed=7, seed_grad=8), axis=None))
    ad = {key: float(np.ravel(dr.grad(params[key]))[0]) for key in keys}
    for key in keys:
        dr.disable_grad(params[key])
    params.update()
    return ad


# -- corrupt tables ------------------------------------------------------------------
def refusal(d):
    """The error loading the BSDF dict d gives, its last line (Mitsuba's parser re-raises the plugin's
    error with its traceback first); None when it loads."""
    try:
        mi.load_dict(d)
    except Exception as e:
        return str(e).strip().splitlines()[-1]
    return None


def test_corrupt(variants_all_spectral, materials, bundle):
    work = Path(tempfile.mkdtemp(prefix="twoscale-test-"))
    try:
        d = work / "rand1"
        shutil.copytree(materials / "rand1", d)
        h5 = d / "zh_lobe.h5"
        data = bytearray(h5.read_bytes())
        data[-100] ^= 0x40  # a value's bytes (the file ends with the value data)
        h5.write_bytes(bytes(data))
        bad_bundle = work / "bad.tar.gz"
        # SHA256SUMS rewritten over the corrupt file (as whoever changed it could): the manifest's checksum catches it.
        sums = work / "SHA256SUMS"
        sums.write_text("".join(f"{hashlib.sha256(f.read_bytes()).hexdigest()}  rand1/{f.name}\n" for f in sorted(d.iterdir())))
        with tarfile.open(bad_bundle, "w:gz") as tar:
            tar.add(d, arcname="twoscale-tables-bad/rand1")
            tar.add(sums, arcname="twoscale-tables-bad/SHA256SUMS")
        for what, path in (("folder", d), ("bundle", bad_bundle)):
            msg = refusal(bsdf_dict(path))
            report(msg is not None and msg.startswith("TwoScaleError: ") and "zh_lobe.h5" in msg and "checksum" in msg,
                  f"corrupt: a corrupt {what} is one clear error: {msg}")
        msg = refusal(bsdf_dict(materials))
        report(msg is not None and "not a material folder" in msg, f"corrupt: a scene folder is not a material folder: {msg}")
        for kw, needle in ((dict(b=0.9), "b = 0.9 differs from the tables' 0.7093"),
                           (dict(lobe="other"), "lobe = 'other': expected \"exact\" or \"fit\""),
                           (dict(fresnel="conductor"), "parameter 'eta' is missing")):
            msg = refusal(bsdf_dict(materials / "rand1", **kw))
            report(msg is not None and needle in msg, f"corrupt: {kw} is one clear error: {msg}")
        # A plastic's or subsurface material's Fresnel factor is its interface's.
        for name, kw, needle in (("plastic1", dict(eta=1.5, k=0.0), "eta is given, but a plastic's Fresnel factor"),
                                 ("subsurface1", dict(fresnel="one"), "fresnel = 'one': a plastic's or subsurface material's")):
            msg = refusal(bsdf_dict(materials / name, **kw))
            report(msg is not None and needle in msg, f"corrupt: {name} with {kw} is one clear error: {msg}")
        msg = refusal(bsdf_dict(bundle))
        report(msg is not None and "several materials: set `material`" in msg,
               f"corrupt: a bundle of several materials needs `material`: {(msg or '')[:140]}...")
    finally:
        shutil.rmtree(work)


def test_bundle_evaluates_as_its_folder(variant_llvm_ad_spectral, materials, bundle):
    a = mi.load_dict(bsdf_dict(bundle, material="rand1"))
    b = mi.load_dict(bsdf_dict(materials / "rand1"))
    wi, wo = np.array([[0.3, 0.0, math.sqrt(0.91)]]), np.array([[-0.28, 0.05, math.sqrt(1 - 0.0809)]])
    same = all(np.array_equal(x, y) for x, y in zip(parts_at(a, wi, wo, 500.0), parts_at(b, wi, wo, 500.0)))
    report(same, f"corrupt: the bundle {Path(bundle).name} (material rand1) loads and evaluates as its folder")


def fmt(where):
    if where is None:
        return "-"
    name, wi, wo, lam = where
    return f"({name}: theta_i={math.degrees(math.acos(wi[2])):.1f} deg, theta_o={math.degrees(math.acos(wo[2])):.1f} deg, lambda={lam:.0f} nm)"
