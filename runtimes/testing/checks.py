"""What the tests of the Mitsuba BSDF (mitsuba/tests) and of the C BRDF (c/tests) share: the
chi-square cases and their chart, the random direction pairs of the brute-force tests, the energy
tests' materials and their half-vector rule; `report`, which prints a check's figures and asserts
it. Mitsuba's variant is the caller's (a fixture sets it)."""
import json
import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
from reference import gauss_panels

# (material of test_materials.toml, theta_i degrees, lambda nm): narrow and broad microfacet lobes,
# small and large p, no / weak / dominant diffraction, narrow (large b) and broad (small b, c near 1)
# diffraction lobes, normal to grazing incidence.
CHI2_CASES = [("chi1", 30, 550), ("chi2", 60, 550), ("chi3", 0, 550), ("chi4", 40, 550), ("chi5", 45, 450),
              ("chi6", 20, 650), ("chi7", 70, 550), ("chi8", 85, 550), ("chi9", 10, 700), ("chi10", 80, 400),
              ("chi11", 50, 500), ("chi12", 0, 600), ("chi13", 89, 550)]
# Plastics (docs/maths.md section 10): a narrow, a heavy-tailed broad and a sharp interface, diffracting
# interfaces (weak, broad lobe), and a coloured layer; normal to grazing incidence.
PLASTIC_CHI2_CASES = [("plastic1", 30, 550), ("plastic2", 60, 550), ("plastic3", 0, 550), ("plastic4", 45, 450),
                      ("plastic5", 80, 600), ("plastic7", 20, 500)]
# White, non-absorbing layers (the furnace) and the coloured one.
PLASTIC_WHITE = [f"plastic{i}" for i in range(1, 7)]
PLASTICS = PLASTIC_WHITE + ["plastic7"]
# Subsurface (docs/maths.md section 11): isotropic, forward and backward scattering, diffracting interfaces,
# and a coloured medium given by its coefficients; the same, white, for the furnace.
SUBSURFACE_CHI2_CASES = [("subsurface1", 30, 550), ("subsurface2", 60, 550), ("subsurface3", 0, 550), ("subsurface4", 45, 450),
                         ("subsurface5", 70, 600), ("subsurface7", 20, 500)]
SUBSURFACE_WHITE = [f"subsurface{i}" for i in range(1, 7)]
SUBSURFACES = SUBSURFACE_WHITE + ["subsurface7"]


def report(ok, what):
    """Prints a check's measured figures, then asserts it."""
    print(what, flush=True)
    assert ok, what


def params_of(folder):
    """The `material` section of a material folder's manifests."""
    return json.loads((Path(folder) / "epd_g1.manifest.json").read_text())["material"]


def is_conductor(folder):
    return params_of(folder).get("model", "conductor") == "conductor"


def energy_wavelengths(m):
    """Three wavelengths (nm) across a material's range (Mitsuba's 360-830 nm without diffraction)."""
    lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.36, 0.83)
    return [1e3 * lo, 1e3 * 0.5 * (lo + hi), 1e3 * hi]


def reciprocity(f_io, f_oi):
    """The largest |f(i, o) - f(o, i)| / max of the two where that max is >= 1e-6 of the largest value."""
    big = np.maximum(f_io, f_oi)
    rel = np.abs(f_io - f_oi) / np.maximum(big, 1e-300)
    rel[big < 1e-6 * big.max()] = 0.0
    return float(rel.max())


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


def chi2_run(sample, pdf, beta, theta_i):
    """mitsuba.chi2 on the tangent-pole chart: 10^6 samples, 200 x 100 cells, significance 0.01 with
    Mitsuba's Sidak correction for the 25 cases (13 conductors, 6 plastics, 6 subsurface). Narrow lobes integrate the pdf
    with 16 x 16 nodes per cell (6 x 6 otherwise): beta < 0.05, or beta <= 0.1 at theta_i >= 75 deg, where the
    reflected lobe is squeezed against the horizon (beta 0.05 at 80 deg: 6 x 6 rejects a correct sampler, p 1e-9,
    for a conductor as for a plastic; 16 x 16 accepts it, p 0.3). (accepted, p-value, messages)."""
    from mitsuba.chi2 import ChiSquareTest

    narrow = beta < 0.05 or (beta <= 0.1 and theta_i >= 75)
    test = ChiSquareTest(domain=TangentPoleDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3,
                         sample_count=1_000_000, res=100, ires=16 if narrow else 6)
    ok = test.run(significance_level=0.01, test_count=len(CHI2_CASES) + len(PLASTIC_CHI2_CASES) + len(SUBSURFACE_CHI2_CASES), quiet=True)
    p = test.p_value
    return ok, float(p[0]) if hasattr(p, "__len__") else float(p), test.messages


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


def random_pairs(rng, beta, near, far):
    """(wi, wo) as [n, 3] arrays: `near` pairs about the mirror direction (random_pair at the lobe's beta), then
    `far` pairs of two directions anywhere above the horizon."""
    pairs = [random_pair(rng, beta) for _ in range(near)]
    pairs += [(random_pair(rng, 1.0)[0], random_pair(rng, 1.0)[0]) for _ in range(far)]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


# energy = "compensated" (test_bsdf.py, test_c_brdf.py) at 18 materials: heavy tails (chi8 p 0.2, chi2
# p 0.3, rand2 p 0.31, furnace2 p 0.5), large beta (chi8 0.5, chi12 0.4, chi2 and chi10 0.3), broad
# diffraction (chi9 b 0.2 um, furnace5 b 0.3 um) and narrow (chi11 b 10 um, chi13 and furnace6 b 16 um), and
# without diffraction (chi1-chi4, furnace2).
ENERGY_MATERIALS = ["chi1", "chi2", "chi3", "chi4", "furnace2", "chi5", "chi6", "chi7", "chi8", "chi9", "chi10",
                    "chi11", "chi12", "chi13", "rand2", "furnace4", "furnace5", "furnace6"]
ENERGY_ANGLES = [0, 15, 30, 45, 60, 70, 75, 80, 85, 87, 89]


class HalfVectorRule:
    """int over o of f(o) do as int over the half vector h of f(2 (i.h) h - i) 4 (i.h) dh: Gauss-Legendre
    in x = ln tan theta_h over [ln 1e-5, ln 1e3] (48 panels x 8 nodes) and in phi over [0, pi] (128 nodes),
    doubled (the BRDF is symmetric about the plane of incidence). Measured on the C BRDF over the energy
    tests' materials, angles and wavelengths, both energy modes: within 1.5e-4 of the rule with 4 times the
    nodes (96 x 8 x 256), whose own error is 2.5e-5 (chi9 compensated at normal incidence, against 384 x 8 x
    512); the tests' tolerances are 1e-2 and 2e-2."""

    def __init__(self):
        xs, xw = gauss_panels(math.log(1e-5), math.log(1e3), 48, 8)
        px, pw = np.polynomial.legendre.leggauss(128)
        x, phi = np.meshgrid(xs, 0.5 * math.pi * (px + 1), indexing="ij")
        t = np.exp(x)
        th = np.arctan(t)
        self.h = np.stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)], -1).reshape(-1, 3)
        self.w = (2.0 * np.outer(xw, 0.5 * math.pi * pw) * np.sin(th) * t / (1 + t * t)).reshape(-1)

    def nodes(self, theta_deg):
        """(i, o [n, 3], weights [n]) at theta_i: int f do = sum f(o) weight, over o above the surface."""
        th = math.radians(theta_deg)
        i = np.array([math.sin(th), 0.0, math.cos(th)])
        ih = self.h @ i
        o = 2.0 * ih[:, None] * self.h - i
        keep = o[:, 2] > 0
        return i, o[keep], 4.0 * ih[keep] * self.w[keep]
