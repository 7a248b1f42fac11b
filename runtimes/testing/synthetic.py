"""Synthetic measured materials for `twoscale fit` (docs/fit.md "How it is checked"): six conductors across the
domain, two plastics and a subsurface material, written as MERL files by merl.py from the brute-force reference (no table), fitted by
`twoscale fit`, and the fitted BRDF evaluated at every valid sample against the noise-free target: a conductor by
the numpy model (twoscale_model.py, the general tables' second reader), a layered one by the C BRDF over the
fitted scene's own tables. Used by pipeline/fit/tests and examples/fit/recovery.py."""
import hashlib
import json
import math
import subprocess
import time
from pathlib import Path

import merl
import numpy as np
import reference
from reference import fresnel
from scipy.interpolate import CubicSpline
from twoscale_c import CBrdf, twoscale_binary
from twoscale_model import TwoScaleModel

LAMBDAS = (0.65, 0.55, 0.45)  # red, green, blue (micrometres)

# Complex indices (eta, k) at 650, 550 and 450 nm, rounded from Johnson & Christy / Rakic-like data.
GOLD = ((0.17, 3.5), (0.43, 2.45), (1.5, 1.9))
NICKEL = ((1.99, 3.75), (1.86, 3.35), (1.73, 2.9))
ALUMINIUM = ((1.5, 7.6), (0.96, 6.7), (0.62, 5.5))
COPPER = ((0.21, 3.6), (1.0, 2.6), (1.2, 2.3))

# name: (beta, p, sigma_s, b, c, index per channel)
MATERIALS = {
    "broad": (0.08, 1.0, 0.05, 0.3, 2.0, NICKEL),  # broad diffraction: B = b / lambda below 0.7
    "narrow": (0.05, 1.5, 0.02, 12.0, 2.8, COPPER),  # narrow diffraction: B up to 27 (a scene's limit is 30)
    "heavy": (0.1, 0.3, 0.01, 2.0, 2.2, ALUMINIUM),  # heavy tails
    "sharp": (0.02, 1.0, 0.005, 1.0, 2.5, GOLD),  # a sharp lobe
    "plain": (0.15, 0.8, 0.0, 1.0, 2.0, NICKEL),  # no diffraction
    "nickel": (0.03, 0.9, 0.004, 0.8, 2.3, NICKEL),  # examples/scenes/merl_nickel.toml
}
NAMES = ("beta", "p", "sigma_s", "b", "c")

# Plastics without diffraction (reference.Plastic has none), name: (beta, p, ior, diffuse per channel).
PLASTICS = {
    "grey_plastic": (0.08, 1.2, 1.5, (0.18, 0.18, 0.17)),  # MERL's gray-plastic-like: a grey layer
    "blue_plastic": (0.2, 0.6, 1.45, (0.05, 0.12, 0.55)),  # broad heavy-tailed coat over a blue layer
}


# Subsurface materials without diffraction, name: (beta, p, ior, reduced albedo per channel, g).
SUBSURFACE = {
    "marble": (0.05, 1.0, 1.5, (0.9, 0.95, 0.99), 0.3),  # a polished, bright, forward-scattering medium
}


def target(name, cache):
    """The noise-free rho [3, 90, 90, 180] of material `name` (NaN below the horizon), cached in `cache`."""
    if name in PLASTICS or name in SUBSURFACE:
        return cached_layered(cache, name)
    beta, p, sigma_s, b, c, index = MATERIALS[name]
    channels = [(lam, eta, k) for lam, (eta, k) in zip(LAMBDAS, index)]
    return merl.cached_conductor(cache, beta=beta, p=p, sigma_s=sigma_s, b=b, c=c, channels=channels)


def layered(name):
    """rho [3, 90, 90, 180] of docs/maths.md section 10 (a plastic) or 11 (subsurface) without diffraction, by
    reference.Plastic or reference.Subsurface (brute force, no table): the interface term at every valid sample;
    T = 1 - E_F from their e_f on 97 incidences uniform in theta_i, interpolated by a cubic spline in theta_i
    (within 1e-6 of e_f); the terms beneath as their eval writes them, on arrays."""
    wi, wo, valid = merl.directions()
    a, b = wi[valid], wo[valid]
    if name in PLASTICS:
        beta, p, ior, diffuse = PLASTICS[name]
        model = reference.Plastic(beta, p, ior, lambda lam: diffuse[LAMBDAS.index(lam)])
    else:
        beta, p, ior, albedo, g = SUBSURFACE[name]
        model = reference.Subsurface(beta, p, ior, lambda lam: albedo[LAMBDAS.index(lam)], g)
    spec = model.interface(a, b)
    thetas = np.linspace(0.0, math.acos(1e-6), 97)
    t = CubicSpline(thetas, [max(1.0 - model.e_f(math.cos(x)), 0.0) for x in thetas])
    tt = t(np.arccos(a[:, 2])) * t(np.arccos(b[:, 2]))
    rho = np.full((3,) + merl.DIMS, np.nan)
    for ch, lam in enumerate(LAMBDAS):
        if name in PLASTICS:
            beneath = model.d_eff(lam) * tt / (math.pi * model.t_avg)
        else:  # reference.Subsurface.eval's terms
            alb = albedo[ch]
            alpha = alb / (alb + (1.0 - alb) * (1.0 - g))
            r = 1.0 - model.t_avg / ior**2
            s3 = math.sqrt(3.0 * (1.0 - alb))
            r_d = 0.5 * alb * (1.0 + math.exp(-4.0 / 3.0 * (1.0 + r) / (1.0 - r) * s3)) * math.exp(-s3)
            mi, mo = (np.sqrt(1.0 - (1.0 - w[:, 2] ** 2) / ior**2) for w in (a, b))
            c = -(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]) / ior**2 - mi * mo
            beneath = r_d * (1.0 - alpha * model.s_max) * tt / (math.pi * model.t_avg)
            beneath = beneath + alpha * tt * reference.henyey_greenstein(c, g) / (ior**2 * (mi + mo))
        rho[ch][valid] = spec + beneath
    return rho


def cached_layered(cache, name):
    params = PLASTICS.get(name) or SUBSURFACE[name]
    text = json.dumps([name, params]) + Path(reference.__file__).read_text() + Path(__file__).read_text()
    path = Path(cache) / f"layered-{hashlib.sha256(text.encode()).hexdigest()[:20]}.npy"
    if path.exists():
        return np.load(path)
    rho = layered(name)
    merl.write_atomically(path, lambda f: np.save(f, rho))
    return rho


def fit(path, tables_root, out_dir, *args):
    """`twoscale fit --json` of the MERL file `path`: (its JSON, the wall time of the command)."""
    out = Path(out_dir) / (Path(path).stem + ".toml")
    cmd = [twoscale_binary(), "fit", str(path), "--out", str(out), "--tables", str(tables_root), "--json", "--quiet", *args]
    start = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {res.stderr.strip()}")
    return json.loads(res.stdout), wall


def fitted_rho(result, tables, folder=None, cache=None):
    """The fitted BRDF at every bin (NaN below the horizon): a conductor by the numpy model (zh_lobe, the exact lobe)
    and the reference's complex Fresnel; a plastic by the C BRDF over `folder`, the fitted scene's built material."""
    wi, wo, valid = merl.directions()
    m = result["material"]
    if m["model"] in ("plastic", "subsurface"):
        brdf = CBrdf(folder, cache_dir=cache)
        rho = np.full((3,) + valid.shape, np.nan)
        for ch, c in enumerate(result["channels"]):
            rho[ch][valid] = brdf.eval(wi[valid], wo[valid], c["wavelength"])
        return rho
    model = TwoScaleModel(tables, m["beta"], m["p"], m["sigma_s"], m["b"] or 1.0, m["c"] or 2.0, lobe="exact")
    a, b = wi[valid], wo[valid]
    h = (a + b) / np.linalg.norm(a + b, axis=1)[:, None]
    cos_d = np.clip((a * h).sum(1), 0.0, 1.0)
    # C depends on theta_h and u = B cos theta_d alone: read at the 90 x 90 (theta_h, theta_d) bins, not at each of
    # a channel's 1.46M samples (half of this function's time). A bin's h and d are its samples' to rounding.
    if model.diffracts:
        theta_h, theta_d, _ = merl.angles()
        i, j, _ = np.nonzero(valid)
        bins = 90 * i + j  # the samples' (theta_h, theta_d) bins, in the order of the grid's cosines below
        bin_cos_h, bin_cos_d = (x.reshape(-1) for x in np.meshgrid(np.cos(theta_h), np.cos(theta_d), indexing="ij"))
    lams = [c["wavelength"] for c in result["channels"]]
    lobes = [model.lobe_c(model.b / lam * bin_cos_d, bin_cos_h)[bins] for lam in lams] if model.diffracts else None
    rho = np.full((3,) + valid.shape, np.nan)
    for ch, (c, (spec, diff)) in enumerate(zip(result["channels"], model.eval_parts_at(a, b, lams, lobes))):
        rho[ch][valid] = fresnel(cos_d, c["eta"], c["k"]) * (spec + diff)
    return rho


def relative_rms(rho, target_rho):
    """sqrt(sum (f - t)^2 / sum t^2) of rho cos theta_i over the bins valid in both, all channels."""
    wi, _, valid = merl.directions()
    ok = valid & np.all(np.isfinite(rho), 0) & np.all(np.isfinite(target_rho), 0)
    cos_i = wi[..., 2][ok]
    f, t = rho[:, ok] * cos_i, target_rho[:, ok] * cos_i
    return math.sqrt(((f - t) ** 2).sum() / (t * t).sum())


def recovered(name, result):
    """[(parameter, true, fitted)] for the surface and each channel's eta and k (a plastic's ior and diffuse)."""
    m, nan = result["material"], float("nan")
    if name in PLASTICS or name in SUBSURFACE:
        beta, p, ior, beneath, *g = PLASTICS.get(name) or SUBSURFACE[name]
        key = "diffuse" if name in PLASTICS else "albedo"
        rows = [("beta", beta, m["beta"]), ("p", p, m["p"]), ("sigma_s", 0.0, m["sigma_s"]), ("ior", ior, m.get("ior", nan))]
        rows += [("g", g[0], m.get("g", nan))] if g else []
        return rows + [(f"{key}[{ch}]", d, result["channels"][ch].get(key, nan)) for ch, d in enumerate(beneath)]
    beta, p, sigma_s, b, c, index = MATERIALS[name]
    rows = [(k, v, float("nan") if m[k] is None else m[k]) for k, v in zip(NAMES, (beta, p, sigma_s, b, c))]
    for ch, (eta, k) in enumerate(index):
        got = result["channels"][ch]
        rows += [(f"eta[{ch}]", eta, got.get("eta", float("nan"))), (f"k[{ch}]", k, got.get("k", float("nan")))]
    return rows
