"""Tests of the C reference BRDF runtimes/c/twoscale_brdf.h over the material folders of
runtimes/testing/test_materials.toml (fixtures: runtimes/conftest.py). `pytest runtimes/c`:

  compile   the header and a material's exported headers compile as C99 (-pedantic) and as C++,
            -Wall -Wextra -Werror; init refuses a material that lacks a table;
  chi2      mitsuba.chi2 accepts the C sample() against the C pdf() at the 13 chi-square cases 6 plastics and 6 subsurface materials, both energy modes;
  brute     eval() against reference.py (quadrature, no tables) at random (i, o, lambda) of the 16 materials;
  furnace   F = 1: the mean weight of sample() equals the quadrature of rho cos theta_o;
  energy    TWOSCALE_ENERGY_COMPENSATED: the furnace is 1 within 1 % over incidence and wavelength,
            rho(i, o) = rho(o, i), no energy created with a conductor.

Each test prints its measured figures (`pytest -rP` shows them).
"""
import math
import subprocess
import time

import numpy as np
import pytest
import reference
from checks import (
    CHI2_CASES,
    ENERGY_ANGLES,
    ENERGY_MATERIALS,
    PLASTIC_CHI2_CASES,
    SUBSURFACE_CHI2_CASES,
    HalfVectorRule,
    chi2_run,
    params_of,
    random_pair,
    random_pairs,
    report,
)
from twoscale_c import C_INCLUDES, CBrdf, twoscale_binary

MATERIALS = [f"chi{i}" for i in range(1, 14)] + ["rand1", "rand2", "rand3"]


def material_params(folder):
    m = params_of(folder)
    return {k: (m[k] or 0.0) for k in ("beta", "p", "sigma_s", "b", "c", "wavelength_min", "wavelength_max")}


# -- compile -----------------------------------------------------------------------
PROGRAM = r"""
#include <stdio.h>
#include MATERIAL_HEADER
int main(void) {
    twoscale_brdf brdf;
    twoscale_material broken = MATERIAL;
    const double wi[3] = {0.6, 0.0, 0.8}, wo[3] = {-0.6, 0.0, 0.8};
    const char *err = twoscale_brdf_init(&brdf, &MATERIAL, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);
    if (err) { printf("init: %s\n", err); return 1; }
    broken.zh_lobe = NULL;
    if (!twoscale_brdf_init(&brdf, &broken, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE)) { printf("init took a material without zh_lobe\n"); return 1; }
    broken = MATERIAL;
    broken.albedo = NULL;
    if (!twoscale_brdf_init(&brdf, &broken, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_COMPENSATED)) {
        printf("compensated init took a material without albedo\n");
        return 1;
    }
    if ((err = twoscale_brdf_init(&brdf, &MATERIAL, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_COMPENSATED))) { printf("compensated init: %s\n", err); return 1; }
    twoscale_brdf_init(&brdf, &MATERIAL, TWOSCALE_LOBE_FIT, TWOSCALE_ENERGY_SINGLE);
    printf("%.17g\n", twoscale_brdf_eval(&brdf, wi, wo, 0.55, twoscale_fresnel_conductor(1.5, 3.0)));
    return 0;
}
"""


@pytest.mark.parametrize("name", ["chi5", "plastic4", "subsurface4"])
def test_compile(materials, tmp_path, name):
    """A conductor's, a plastic's and a subsurface material's exported headers (all diffracting, so that init must
    refuse them without zh_lobe)."""
    work = tmp_path
    out = subprocess.run([twoscale_binary(), "export", "--quiet", "--format", "c-header", "--dir", str(materials / name), "--out", str(work)],
                         capture_output=True, text=True)
    report(out.returncode == 0, f"compile: export of {name} {out.stderr.strip()}")
    header = next(work.glob("twoscale_material_*.h"))
    src = work / "program.c"
    src.write_text(PROGRAM)
    values = []
    for compiler, flags in (("cc", ["-std=c99", "-pedantic"]), ("g++", ["-x", "c++"])):
        exe = work / f"program-{compiler}"
        cmd = [compiler, *flags, "-O2", "-Wall", "-Wextra", "-Werror", f"-DMATERIAL_HEADER=\"{header.name}\"", f"-DMATERIAL={header.stem}",
               *C_INCLUDES, "-I", str(work), str(src), "-o", str(exe), "-lm"]
        res = subprocess.run(cmd, capture_output=True, text=True)
        run = subprocess.run([str(exe)], capture_output=True, text=True) if res.returncode == 0 else None
        ok = run is not None and run.returncode == 0
        report(ok, f"compile: {name}: {' '.join(cmd[:-6] + ['...'])}: compiles without a warning, init refuses a material without zh_lobe "
                   "(or albedo, compensated)" + ("" if ok else f"\n{res.stderr}{run.stdout if run else ''}"))
        if ok:
            values.append(float(run.stdout))
    report(len(values) == 2 and values[0] == values[1] and values[0] > 0, f"compile: {name}: C and C++ give the same rho ({values})")


# -- chi2 -------------------------------------------------------------------------
@pytest.mark.parametrize("energy", ["single", "compensated"])
@pytest.mark.parametrize("name, theta, lam_nm", CHI2_CASES + PLASTIC_CHI2_CASES + SUBSURFACE_CHI2_CASES)
def test_chi2(variant_llvm_ad_rgb, materials, c_cache, name, theta, lam_nm, energy):
    import mitsuba as mi

    brdf = CBrdf(materials / name, "exact", c_cache, energy=energy)
    m = material_params(materials / name)
    th = math.radians(theta)
    wi = np.array([math.sin(th), 0.0, math.cos(th)])
    lam = lam_nm * 1e-3

    def sample(s):
        s = np.asarray(s, np.float64)  # [3, n]
        wo, pdf, _ = brdf.sample(wi, lam, s[0], s[1])
        return mi.Vector3f(wo.T.astype(np.float32)), mi.Float((pdf > 0).astype(np.float32))

    def pdf(wo):
        return mi.Float(brdf.pdf(wi, np.asarray(wo, np.float64).T, lam).astype(np.float32))

    t0 = time.time()
    ok, pv, msg = chi2_run(sample, pdf, m["beta"], theta)
    report(ok, f"chi2{'' if energy == 'single' else ' (compensated)'}: {name} beta={m['beta']} p={m['p']} sigma_s={m['sigma_s']} "
               f"b={m['b']} c={m['c']} theta_i={theta} lambda={lam_nm}: p-value {pv:.3g} ({time.time() - t0:.1f} s)" + ("" if ok else "\n" + msg))


# -- brute force --------------------------------------------------------------------
def test_brute(materials, c_cache, per_material=16):
    rng = np.random.default_rng(27)
    spec_err, diff_err, f_err = [], [], []
    worst = {"spec": (0.0, None), "diff": (0.0, None)}
    misses = []
    t0 = time.time()
    for name in MATERIALS:
        m = material_params(materials / name)
        brdf = CBrdf(materials / name, "exact", c_cache)
        lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m["sigma_s"] > 0 else (0.36, 0.83)
        for _ in range(per_material):
            wi, wo = random_pair(rng, m["beta"])
            lam = rng.uniform(lo, hi)
            eta, k = rng.uniform(0.2, 2.5), rng.uniform(1.0, 5.0)
            spec_c, diff_c = (x[0] for x in brdf.eval_parts(wi, wo, lam))
            got = brdf.eval(wi, wo, lam, eta=eta, k=k)[0]
            spec, diff, peak, f = reference.brdf(wi, wo, lam, m["beta"], m["p"], m["sigma_s"], m["b"], m["c"], eta, k)
            # D is 0 where exp(-y^p) < e^-104, below float32 (docs/runtimes.md); reference.py keeps it in double.
            h = np.asarray(wi) + np.asarray(wo)
            cut = ((h[0] ** 2 + h[1] ** 2) / (h[2] ** 2 * m["beta"] ** 2)) ** m["p"] >= 104.0
            e = abs(spec_c - spec) / spec if spec > 0 and not cut else (0.0 if spec_c == 0 else math.inf)
            spec_err.append(e)
            if e > worst["spec"][0]:
                worst["spec"] = (e, (name, wi, wo, lam))
            total = f * (spec_c + diff_c)
            f_err.append(abs(got - total) / total if total > 0 else abs(got))
            if m["sigma_s"] > 0:
                # zh_lobe's accuracy is counted where C >= 1e-4 of its maximum at that u (docs/material_tables.md)
                if diff >= 1e-4 * peak:
                    e = abs(diff_c - diff) / diff
                    diff_err.append(e)
                    if e > worst["diff"][0]:
                        worst["diff"] = (e, (name, wi, wo, lam))
                    if e > 3e-3:
                        misses.append((name, e, diff / peak, wi, wo, lam))
    n = len(spec_err)

    def where(w):
        name, wi, wo, lam = w
        return f"{name} wi={np.round(wi, 4).tolist()} wo={np.round(wo, 4).tolist()} lambda={lam:.4f}"

    report(max(spec_err) < 1e-3, f"brute: {n} random (i, o, lambda) over {len(MATERIALS)} materials ({time.time() - t0:.0f} s): specular part "
                                f"relative error median {np.median(spec_err):.2e}, max {max(spec_err):.2e} (tol 1e-3) at {where(worst['spec'][1])}")
    report(max(diff_err) < 3e-3, f"brute: diffraction part at {len(diff_err)} points where C >= 1e-4 of its peak: relative error median "
                                f"{np.median(diff_err):.2e}, p99 {np.percentile(diff_err, 99):.2e}, max {max(diff_err):.2e} (tol 3e-3) at "
                                f"{where(worst['diff'][1])}")
    for name, e, frac, wi, wo, lam in misses:
        print(f"      diffraction miss: {name} rel. error {e:.2e} where C is {frac:.2e} of its peak, {where((name, wi, wo, lam))}")
    report(max(f_err) < 1e-12, f"brute: eval() = F (specular + diffraction) with the conductor Fresnel factor, max rel. diff {max(f_err):.1e}")


# -- white furnace -------------------------------------------------------------------
def hemisphere_integral(brdf, wi, lam, n_theta=600, n_phi=256):
    """int rho cos theta_o do over the half vector: do = 4 |i.h| dh, theta_h on a geometric grid (midpoints) from 1e-6."""
    x = np.concatenate([[0.0], np.geomspace(1e-6, math.pi / 2, n_theta)])
    th, dth = 0.5 * (x[1:] + x[:-1]), np.diff(x)
    ph = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
    T, P = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    idoth = h @ wi
    wo = 2 * idoth[:, None] * h - wi
    rho = np.where((wo[:, 2] > 0) & (idoth > 0), brdf.eval(wi, wo, lam), 0.0)
    dw = (np.sin(T) * dth[:, None] * (2 * math.pi / n_phi)).reshape(-1) * 4 * np.abs(idoth)
    return float(np.sum(rho * np.clip(wo[:, 2], 0, None) * dw))


def test_furnace(materials, c_cache, n=400_000):
    rng = np.random.default_rng(3)
    worst = 0.0  # largest |mean weight - quadrature| / quadrature
    for name, lam in (("chi1", 0.55), ("chi2", 0.55), ("chi5", 0.45), ("chi7", 0.55), ("chi11", 0.5), ("rand3", 0.6)):
        brdf = CBrdf(materials / name, "exact", c_cache)
        for deg in (0, 40, 75):
            th = math.radians(deg)
            wi = np.array([math.sin(th), 0.0, math.cos(th)])
            _, pdf, w = brdf.sample(wi, lam, rng.random(n), rng.random(n))
            mc, err = w.mean(), w.std() / math.sqrt(n)
            quad = hemisphere_integral(brdf, wi, lam)
            worst = max(worst, abs(mc - quad) / quad)
            report(abs(mc - quad) < 4 * err + 2e-3 * quad, f"furnace: {name} theta_i={deg} lambda={lam}: mean weight {mc:.5f} +- {err:.5f}, "
                                                         f"quadrature of rho cos {quad:.5f} (tol 4 sigma + 2e-3)")
    print(f"      furnace: largest relative departure of the mean weight from the quadrature {worst:.2e}")


# -- energy compensation -------------------------------------------------------------
def rule_albedo(rule, brdf, theta_deg, lam, eta=None, k=None):
    """int rho cos theta_o do at theta_i by the half-vector rule of checks.py."""
    i, o, w = rule.nodes(theta_deg)
    return float((brdf.eval(i, o, lam, eta=eta, k=k) * o[:, 2] * w).sum())


def test_energy(materials, c_cache):
    rule = HalfVectorRule()
    worst, most, recip = (0.0, None), (0.0, None), (0.0, None)
    rng = np.random.default_rng(47)
    for name in ENERGY_MATERIALS:
        m = material_params(materials / name)
        lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m["sigma_s"] else (0.36, 0.83)
        brdf = CBrdf(materials / name, "exact", c_cache, energy="compensated")
        for lam in (lo, 0.5 * (lo + hi), hi):
            row = []
            for deg in ENERGY_ANGLES:
                e = rule_albedo(rule, brdf, deg, lam)
                row.append(e)
                if abs(e - 1) > worst[0]:
                    worst = (abs(e - 1), (name, deg, lam))
            print(f"      energy {name} lambda={lam:.3f}: compensated albedo by theta_i {ENERGY_ANGLES}: {' '.join(f'{e:.4f}' for e in row)}")
        for deg in (0, 60, 85, 89):
            e = rule_albedo(rule, brdf, deg, 0.5 * (lo + hi), eta=0.2, k=3.4)
            if e > most[0]:
                most = (e, (name, deg))
        wi, wo = random_pairs(rng, m["beta"], 500, 500)
        lam = rng.uniform(lo, hi, len(wi))
        for eta, k in ((None, None), (np.full(len(wi), 0.2), np.full(len(wi), 3.4))):
            a, b = brdf.eval(wi, wo, lam, eta=eta, k=k), brdf.eval(wo, wi, lam, eta=eta, k=k)
            big = np.maximum(a, b)
            rel = np.where(big > 1e-9 * big.max(), np.abs(a - b) / np.maximum(big, 1e-300), 0.0)
            if rel.max() >= recip[0]:
                recip = (float(rel.max()), name)
    report(worst[0] < 0.01, f"energy: compensated furnace within 1 % of 1 at {len(ENERGY_MATERIALS)} materials x {len(ENERGY_ANGLES)} angles "
          f"(0-89 deg) x 3 wavelengths: largest departure {worst[0]:.4f} at {worst[1]}")
    report(most[0] <= 1.0 + 1e-3, f"energy: compensated with a conductor (0.2 + 3.4i): largest albedo {most[0]:.4f} at {most[1]} (<= 1)")
    report(recip[0] <= 1e-6, f"energy: rho(i, o) = rho(o, i) at 1000 pairs per material, F = 1 and a conductor: largest relative "
          f"difference {recip[0]:.2g} at {recip[1]} (tol 1e-6)")
