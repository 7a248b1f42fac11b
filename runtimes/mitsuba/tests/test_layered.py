"""Tests of the Mitsuba BSDF `twoscale` on the layered materials of runtimes/testing/test_materials.toml:
the plastics (docs/maths.md section 10) and the subsurface materials (section 11); the chi-square cases are
test_bsdf.py's. `pytest runtimes/mitsuba -k layered`:

  furnace      white, non-absorbing layers: over theta_i 0-89 deg and three wavelengths, a plastic's albedo
               is within 2 % of 1 and at most 1.01, a subsurface material's at most 1 (below it by the
               stated single-scattering bound: printed), both energy modes; coloured layers stay below 1;
  reciprocity  rho(i, o) = rho(o, i): compensated everywhere, single where the interface does not diffract
               (the paper's diffraction part is not reciprocal: measured and printed);
  brute        eval against reference.Plastic / reference.Subsurface (quadrature, no tables) at 200 random points;
  c            the C BRDF and this BSDF agree: eval, pdf;
  grad         d(render)/d(sigma_s, b, and the layer's diffuse or albedo) by dr.backward against central finite
               differences, a plastic and a subsurface material.

Each test prints its measured figures (`pytest -rP` shows them).
"""
import time

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
import reference
import twoscale_mitsuba  # noqa: F401  (registers the plugin for every spectral variant)
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
from test_bsdf import adjoint, bsdf_dict, hemisphere_albedo, make_si, scene_dict, vec3


def rho(bsdf, wi, wo, lam_nm):
    """eval / cos theta_o at arrays of directions [n, 3] and wavelengths (nm)."""
    si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam_nm, len(wi))
    return np.asarray(bsdf.eval(mi.BSDFContext(), si, vec3(wo))[0], dtype=np.float64) / wo[:, 2]


# model: (its materials, its white ones, the layer's albedo key)
MODELS = {"plastic": (PLASTICS, PLASTIC_WHITE, "diffuse"), "subsurface": (SUBSURFACES, SUBSURFACE_WHITE, "albedo")}


def layer_spectrum(m, key):
    d = m[key]
    return (lambda lam: d) if isinstance(d, (int, float)) else (lambda lam: float(np.interp(lam, d["wavelengths"], d["values"])))


def test_layered_furnace_plastic(variant_llvm_ad_spectral, materials):
    rule = HalfVectorRule()
    worst = {"single": (0.0, None), "compensated": (0.0, None)}
    highest = 0.0
    coloured = 0.0
    for name in PLASTICS:
        m = params_of(materials / name)
        for energy in ("single", "compensated"):
            bsdf = mi.load_dict(bsdf_dict(materials / name, energy=energy))
            for lam in energy_wavelengths(m):
                row = [hemisphere_albedo(rule, bsdf, deg, lam) for deg in ENERGY_ANGLES]
                print(f"      plastic furnace {name} (beta {m['beta']:g}, p {m['p']:g}, sigma_s {m['sigma_s']:g}, ior {m['ior']:g}, "
                      f"diffuse {m['diffuse']}) {energy} lambda={lam:.0f}: {' '.join(f'{e:.5f}' for e in row)}", flush=True)
                if name in PLASTIC_WHITE:
                    j = int(np.argmax(np.abs(np.array(row) - 1)))
                    if abs(row[j] - 1) > worst[energy][0]:
                        worst[energy] = (abs(row[j] - 1), (name, ENERGY_ANGLES[j], round(lam)))
                    highest = max(highest, max(row))
                else:
                    coloured = max(coloured, max(row))
    for energy in ("single", "compensated"):
        report(worst[energy][0] <= 0.02, f"plastic furnace ({energy}): white layers, {len(PLASTIC_WHITE)} materials x {len(ENERGY_ANGLES)} "
              f"angles (0-89 deg) x 3 wavelengths: largest |albedo - 1| {worst[energy][0]:.2e} at {worst[energy][1]} (tol 2 %)")
    report(highest <= 1.01, f"plastic furnace: the largest albedo of a white layer {highest:.5f} (<= 1.01)")
    report(coloured < 1.0, f"plastic furnace: the coloured layer's largest albedo {coloured:.4f} (< 1)")


def test_layered_furnace_subsurface(variant_llvm_ad_spectral, materials):
    """A white medium's albedo stays at or below 1 (to the tables' rounding): below it by T(i) alpha (s_max - s_T(i)),
    the stated bound of docs/maths.md section 11."""
    rule = HalfVectorRule()
    highest, lowest, coloured, below_bound = (0.0, None), (2.0, None), 0.0, []
    for name in SUBSURFACES:
        m = params_of(materials / name)
        for energy in ("single", "compensated"):
            bsdf = mi.load_dict(bsdf_dict(materials / name, energy=energy))
            for lam in energy_wavelengths(m):
                row = [hemisphere_albedo(rule, bsdf, deg, lam) for deg in ENERGY_ANGLES]
                print(f"      subsurface furnace {name} (beta {m['beta']:g}, p {m['p']:g}, sigma_s {m['sigma_s']:g}, ior {m['ior']:g}, "
                      f"g {m['g']:g}, s_max {m['single_max']:.4f}) {energy} lambda={lam:.0f}: {' '.join(f'{e:.4f}' for e in row)}", flush=True)
                if name in SUBSURFACE_WHITE:
                    # the deficit T(i) alpha (s_max - s_T(i)) is at most s_max (alpha = 1, T <= 1)
                    if min(row) < 1.0 - m["single_max"] - 2e-5:
                        below_bound.append((name, energy, round(lam), min(row), 1.0 - m["single_max"]))
                    if max(row) > highest[0]:
                        highest = (max(row), (name, energy, round(lam)))
                    if min(row) < lowest[0]:
                        lowest = (min(row), (name, energy, round(lam)))
                else:
                    coloured = max(coloured, max(row))
    report(highest[0] <= 1.0 + 2e-5, f"subsurface furnace: white media, {len(SUBSURFACE_WHITE)} materials x {len(ENERGY_ANGLES)} angles (0-89 deg) "
          f"x 3 wavelengths x 2 energy modes: albedo from {lowest[0]:.4f} at {lowest[1]} to {highest[0]:.5f} at {highest[1]} (<= 1 + 2e-5)")
    report(not below_bound, f"subsurface furnace: every white medium's albedo at least 1 - s_max (the bound's largest deficit): "
                            f"{below_bound or 'all'}")
    report(coloured < 1.0, f"subsurface furnace: the coloured medium's largest albedo {coloured:.4f} (< 1)")


@pytest.mark.parametrize("model", ["plastic", "subsurface"])
def test_layered_reciprocity(variant_llvm_ad_spectral, materials, model):
    rng = np.random.default_rng(53)
    worst = {"compensated": (0.0, None), "single": (0.0, None), "single, diffracting": (0.0, None)}
    for name in MODELS[model][0]:
        m = params_of(materials / name)
        wi, wo = random_pairs(rng, m["beta"], 500, 500)
        lam = rng.uniform(*energy_wavelengths(m)[::2], len(wi))
        for energy in ("single", "compensated"):
            bsdf = mi.load_dict(bsdf_dict(materials / name, energy=energy))
            r = reciprocity(rho(bsdf, wi, wo, lam), rho(bsdf, wo, wi, lam))
            key = "single, diffracting" if energy == "single" and m["sigma_s"] > 0 else energy
            if r >= worst[key][0]:
                worst[key] = (r, name)
    report(worst["compensated"][0] <= 1e-6 and worst["single"][0] <= 1e-6,
           f"{model} reciprocity: rho(i, o) = rho(o, i) at 1000 pairs per material: compensated, largest relative difference "
           f"{worst['compensated'][0]:.2g} at {worst['compensated'][1]}; single without diffraction {worst['single'][0]:.2g} at "
           f"{worst['single'][1]} (tol 1e-6); single with diffraction (the paper's R(theta_i), not reciprocal) "
           f"{worst['single, diffracting'][0]:.3g} at {worst['single, diffracting'][1]}")


@pytest.mark.parametrize("model", ["plastic", "subsurface"])
def test_layered_brute(variant_llvm_ad_spectral, materials, model, per_material=50):
    """eval against reference.Plastic or reference.Subsurface (E_F by quadrature, G1 from smith_lambda, s_max by
    dblquad) where the value is >= 1e-4 of the largest at the material's points, for the materials without
    diffraction (a diffracting interface is the conductor's code, tested by test_bsdf.py's brute test, and its
    E_F by interface_albedo's manifest)."""
    rng = np.random.default_rng(59)
    errs, worst = [], (0.0, None)
    t0 = time.time()
    names = [n for n in MODELS[model][0] if not params_of(materials / n)["sigma_s"]]
    for name in names:
        m = params_of(materials / name)
        layer = layer_spectrum(m, MODELS[model][2])
        if model == "plastic":
            ref = reference.Plastic(m["beta"], m["p"], m["ior"], layer)
        else:
            ref = reference.Subsurface(m["beta"], m["p"], m["ior"], layer, m["g"])
        bsdf = mi.load_dict(bsdf_dict(materials / name))
        wi, wo = (x.astype(np.float32).astype(np.float64) for x in random_pairs(rng, m["beta"], per_material // 2, per_material - per_material // 2))
        lam = rng.uniform(0.38, 0.78, len(wi)).astype(np.float32).astype(np.float64)
        got = rho(bsdf, wi, wo, lam * 1e3)
        want = np.array([ref.eval(a, b, x)[0] for a, b, x in zip(wi, wo, lam)])
        rel = np.abs(got - want) / want
        rel[want < 1e-4 * want.max()] = 0.0
        errs.extend(rel)
        if rel.max() > worst[0]:
            worst = (float(rel.max()), name)
    report(max(errs) <= 1e-3, f"{model} brute: eval against the reference at {len(errs)} random points of {', '.join(names)} "
          f"({time.time() - t0:.0f} s): relative error median {np.median(errs):.2e}, max {max(errs):.2e} at {worst[1]} (tol 1e-3)")


@pytest.mark.parametrize("model", ["plastic", "subsurface"])
@pytest.mark.parametrize("energy", ["single", "compensated"])
def test_layered_c(variant_llvm_ad_spectral, materials, c_cache, energy, model):
    """The C BRDF (twoscale_c.py) and this BSDF on the same float32 inputs: eval and pdf at random points."""
    from twoscale_c import CBrdf

    rng = np.random.default_rng(61)
    worst = {"eval": (0.0, None), "pdf": (0.0, None)}
    names = MODELS[model][0]
    for name in names:
        m = params_of(materials / name)
        wi, wo = (x.astype(np.float32).astype(np.float64) for x in random_pairs(rng, m["beta"], 100, 100))
        lam = rng.uniform(*energy_wavelengths(m)[::2], len(wi)).astype(np.float32).astype(np.float64)
        for lobe in ("exact", "fit") if m["sigma_s"] else ("exact",):
            c = CBrdf(materials / name, lobe=lobe, cache_dir=c_cache, energy=energy)
            bsdf = mi.load_dict(bsdf_dict(materials / name, lobe=lobe, energy=energy))
            si = make_si([wi[:, 0], wi[:, 1], wi[:, 2]], lam, len(wi))
            v, pdf = bsdf.eval_pdf(mi.BSDFContext(), si, vec3(wo))
            v = np.asarray(v[0], dtype=np.float64) / wo[:, 2]
            want, pdf_c = c.eval(wi, wo, lam * 1e-3), c.pdf(wi, wo, lam * 1e-3)
            for key, a, b in (("eval", v, want), ("pdf", np.asarray(pdf, dtype=np.float64), pdf_c)):
                rel = float((np.abs(a - b) / b)[b > 0].max())
                if rel > worst[key][0]:
                    worst[key] = (rel, f"{name} {lobe}")
    report(worst["eval"][0] <= 1e-5 and worst["pdf"][0] <= 2e-4,
           f"{model} c ({energy}): the C BRDF and this BSDF at 200 points x {len(names)} materials: eval max rel. diff "
           f"{worst['eval'][0]:.2e} at {worst['eval'][1]} (tol 1e-5), pdf {worst['pdf'][0]:.2e} at {worst['pdf'][1]} (tol 2e-4: float32 "
           f"quantile cells and the cosine share's texture)")


@pytest.mark.parametrize("material, layer", [("plastic4", "diffuse"), ("subsurface4", "albedo")])
def test_layered_grad(variant_llvm_ad_spectral, materials, material, layer):
    """As test_bsdf.py's test_grad, on a diffracting plastic and subsurface material: d(mean image)/d(sigma_s, b, and the
    layer's albedo)."""
    d = scene_dict(bsdf_dict(materials / material, energy="compensated"), res=24, spp=4, integrator={"type": "prb", "max_depth": 2})
    del d["env"]
    scene = mi.load_dict(d)
    params = mi.traverse(scene)
    keys = {"sigma_s": "sphere.bsdf.sigma_s", "b": "sphere.bsdf.b", layer: f"sphere.bsdf.{layer}"}
    base = {name: float(np.ravel(params[key])[0]) for name, key in keys.items()}
    base[layer] = 0.7  # inside (0, 1), where a central difference is defined
    params[keys[layer]] = dr.opaque(type(params[keys[layer]]), 0.7)
    params.update()

    def set_value(name, value):
        params[keys[name]] = dr.opaque(type(params[keys[name]]), value)
        params.update()

    def loss_at(name, value):
        set_value(name, value)
        out = float(np.ravel(dr.mean(mi.render(scene, params, seed=8), axis=None))[0])
        set_value(name, base[name])
        return out

    ad = adjoint(scene, params, keys.values())
    for name, key in keys.items():
        h = 1e-2 * base[name]
        fd = (loss_at(name, base[name] + h) - loss_at(name, base[name] - h)) / (2 * h)
        report(abs(ad[key] - fd) <= 0.02 * abs(fd) and fd != 0, f"layered grad: {material}: d(mean image)/d {name} at {base[name]:g}: "
               f"dr.backward {ad[key]:.5g}, central difference (h = {h:.3g}) {fd:.5g} ({ad[key] / fd - 1:+.2%}, tol 2 %)")
