"""Tests of the C reference BRDF on the layered materials of runtimes/testing/test_materials.toml: the plastics
(docs/maths.md section 10) and the subsurface materials (section 11); the chi-square cases are test_c_brdf.py's.
`pytest runtimes/c -k layered`:

  furnace      white, non-absorbing layers over theta_i 0-89 deg and three wavelengths, both energy modes: a
               plastic's albedo within 2 % of 1 and at most 1.01, a subsurface material's at most 1; sample()'s
               mean weight agrees with the quadrature;
  reciprocity  rho(i, o) = rho(o, i): compensated, and single where the interface does not diffract.

Each test prints its measured figures (`pytest -rP` shows them).
"""
import math

import numpy as np
from checks import (
    ENERGY_ANGLES,
    PLASTIC_WHITE,
    PLASTICS,
    SUBSURFACE_WHITE,
    SUBSURFACES,
    HalfVectorRule,
    energy_wavelengths,
    params_of,
    random_pairs,
    reciprocity,
    report,
)
from twoscale_c import CBrdf


def rule_albedo(rule, brdf, theta_deg, lam):
    i, o, w = rule.nodes(theta_deg)
    return float((brdf.eval(i, o, lam) * o[:, 2] * w).sum())


def test_c_layered_furnace(materials, c_cache, n=200_000):
    rule = HalfVectorRule()
    rng = np.random.default_rng(67)
    worst = {"single": (0.0, None), "compensated": (0.0, None)}
    highest, mc_worst, sss = 0.0, 0.0, (2.0, 0.0)
    for name in PLASTIC_WHITE + SUBSURFACE_WHITE:
        m = params_of(materials / name)
        for energy in ("single", "compensated"):
            brdf = CBrdf(materials / name, "exact", c_cache, energy=energy)
            for lam in (x * 1e-3 for x in energy_wavelengths(m)):
                row = [rule_albedo(rule, brdf, deg, lam) for deg in ENERGY_ANGLES]
                if name in SUBSURFACE_WHITE:
                    sss = (min(sss[0], min(row)), max(sss[1], max(row)))
                    # the deficit T(i) alpha (s_max - s_T(i)) is at most s_max (alpha = 1, T <= 1)
                    report(min(row) >= 1.0 - m["single_max"] - 2e-5, f"subsurface furnace (C): {name} {energy} lambda={lam:.3f}: "
                                                                      f"albedo {min(row):.4f} - {max(row):.4f} (>= 1 - s_max = {1 - m['single_max']:.4f})")
                    continue
                j = int(np.argmax(np.abs(np.array(row) - 1)))
                if abs(row[j] - 1) > worst[energy][0]:
                    worst[energy] = (abs(row[j] - 1), (name, ENERGY_ANGLES[j], round(lam * 1e3)))
                highest = max(highest, max(row))
            # sample()'s mean weight at 60 deg: an estimate independent of the quadrature
            wi = np.array([math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))])
            lam = energy_wavelengths(m)[1] * 1e-3
            _, _, w = brdf.sample(wi, lam, rng.random(n), rng.random(n))
            err = w.std() / math.sqrt(n)
            want = rule_albedo(rule, brdf, 60, lam)
            mc_worst = max(mc_worst, abs(w.mean() - want) / err)
            report(abs(w.mean() - want) < 4 * err + 1e-3, f"layered furnace (C): {name} {energy}, sample()'s mean weight at 60 deg "
                                                          f"{w.mean():.5f} +- {err:.5f}, quadrature {want:.5f} (within 4 sigma + 1e-3)")
    for energy in ("single", "compensated"):
        report(worst[energy][0] <= 0.02, f"plastic furnace (C, {energy}): white layers, {len(PLASTIC_WHITE)} materials x "
              f"{len(ENERGY_ANGLES)} angles (0-89 deg) x 3 wavelengths: largest |albedo - 1| {worst[energy][0]:.2e} at {worst[energy][1]} "
              f"(tol 2 %)")
    report(highest <= 1.01, f"plastic furnace (C): the largest albedo of a white layer {highest:.6f} (<= 1.01)")
    report(sss[1] <= 1.0 + 2e-5, f"subsurface furnace (C): white media, {len(SUBSURFACE_WHITE)} materials x {len(ENERGY_ANGLES)} angles x 3 "
                                f"wavelengths x 2 energy modes: albedo from {sss[0]:.4f} to {sss[1]:.5f} (<= 1 + 2e-5)")


def test_c_layered_reciprocity(materials, c_cache):
    rng = np.random.default_rng(71)
    worst = {"compensated": (0.0, None), "single": (0.0, None), "single, diffracting": (0.0, None)}
    for name in PLASTICS + SUBSURFACES:
        m = params_of(materials / name)
        wi, wo = random_pairs(rng, m["beta"], 500, 500)
        lam = rng.uniform(*energy_wavelengths(m)[::2], len(wi)) * 1e-3
        for energy in ("single", "compensated"):
            brdf = CBrdf(materials / name, "exact", c_cache, energy=energy)
            r = reciprocity(brdf.eval(wi, wo, lam), brdf.eval(wo, wi, lam))
            key = "single, diffracting" if energy == "single" and m["sigma_s"] > 0 else energy
            if r >= worst[key][0]:
                worst[key] = (r, name)
    report(worst["compensated"][0] <= 1e-6 and worst["single"][0] <= 1e-6,
           f"layered reciprocity (C): plastics and subsurface, 1000 pairs per material: compensated, largest relative difference {worst['compensated'][0]:.2g} "
           f"at {worst['compensated'][1]}; single without diffraction {worst['single'][0]:.2g} at {worst['single'][1]} (tol 1e-6); single "
           f"with diffraction (the paper's R(theta_i), not reciprocal) {worst['single, diffracting'][0]:.3g} at {worst['single, diffracting'][1]}")
