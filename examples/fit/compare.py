"""A measured BRDF and the six models `twoscale fit --compare` fits to it, rendered on one sphere, with the error.

The talk's comparison: the three two-scale models and three microfacet-plus-Lambert models, fitted to the same
measured file on the same samples and loss, compared by their fitting error (from the fit's JSON) and by the error of
a render (SMAPE against the render of the file itself). The file (--file, MERL or RGL; default out_of_family.py's
--material, by default ggx_conductor_lambert, written into --work) is fitted by `twoscale fit FILE --compare --json`
unless --fit names that JSON already.

The scene is twoscale's own (pipeline/fit/src/render.rs, docs/fit.md "The render"), which gives every model's
`render_smape` in the JSON; this script renders it through another path (the runtimes, Mitsuba's `measured` plugin for
an RGL file, numpy) and prints its SMAPE beside the JSON's: they agree within 2 % relative, or one of the two is wrong.

The render: a unit sphere seen orthographically along -z (the camera on +z: wo = +z at every pixel), one sample at
each pixel's centre, radiance = sum over the lights of E rho(wi, wo) cos_i in the shading frame of the sphere's normal
(any tangent: the BRDFs are isotropic). The lights (lights()), in the camera's frame, x right, y up:
  - a key light from the upper left, its highlight on the upper left at theta_d 23 deg; where it lights the sphere
    away from that highlight (the lower left) the render is the diffuse part and the lobe's tails;
  - a rim light from behind on the right, its highlight near the right edge at theta_d 74 deg: grazing reflection,
    where Fresnel factors and shadowing differ most;
  - a sky: 120 directions of a Fibonacci lattice over the upper hemisphere (y > 0), equal solid angles, bluish and
    brighter towards the zenith: blurred reflections over the top, and fill light.
The BRDFs at the pairs (wi, wo), the models' exactly:
  - an RGL file: Mitsuba's `measured` plugin (runtimes/testing/mitsuba_measured.py), its si.wi towards the camera and
    its wo towards the light, as Mitsuba renders the file: BSDF::eval is then rho cos_i of the light;
  - a MERL file: trilinear in MERL's bin coordinates (theta_h's index sqrt(theta_h / (pi/2)) 90, theta_d's theta_d /
    (pi/2) 90, phi_d's phi_d / pi 180, phi_d folded into [0, pi) as MERL's lookup does, periodic there by
    reciprocity; theta_h and theta_d clamped to the last bin). A sample marked negative (below the horizon) takes no
    part: the weights of the valid corners are renormalised, and a point with no valid corner is 0 (counted);
  - twoscale_conductor: the numpy model (runtimes/testing/twoscale_model.py, the exact lobe) over the general tables
    and the exact conductor Fresnel factor, as synthetic.fitted_rho;
  - twoscale_plastic, twoscale_subsurface: the C BRDF (twoscale_c.CBrdf) over the material folder `twoscale build
    --scene` makes of a scene file written from the JSON's material;
  - ggx_lambert, beckmann_lambert, epd_lambert: F D G2 / (4 cos_i cos_o) + kd / pi, written here
    (microfacet_lambert; no Rust): out_of_family.py's conductor Fresnel factor and formulas for GGX and Beckmann,
    reference.py's N(p) and Lambda for the EPD.
Errors over the sphere's pixels and the three channels: SMAPE = mean |f - t| / ((|f| + |t|) / 2), the pixel-channels
where both are 0 left out (unlit by every light); and the relative RMS sqrt(sum (f - t)^2 / sum t^2). On a file
written from --material, a member of one comparison model, it also renders that model at the file's true parameters:
its SMAPE against the file's render is the interpolation's error (0.13 % on ggx_conductor_lambert at 160 x 160 with the 96-direction sky it had then).

Writes --out (default docs/renders/fit_compare.png): the file's render and the six models', each labelled with its
SMAPE, and below them log2 of each model's render over the file's (channels summed), blue half to red twice. Prints
a markdown table: model, parameters, the fit's relative and log RMS, the render's SMAPE and relative RMS.

    .venv/bin/python -m examples.fit.compare [--file FILE.binary | --material NAME] [--fit FILE.fit.json]
                                             [--out PNG] [--res N] [--tables tables-out] [--work DIR]

Needs the default preset's general tables (`make tables`), the twoscale binary (target/release, or $TWOSCALE_BIN)
with `fit --compare`, a C compiler (the C BRDF), and Mitsuba for the PNG (examples/fit/render.py's writer and
font). On 2 cores the fit takes about a minute, the rest 20-40 s; the layered materials' folders are kept in --work
(built again only when their parameters or the binary change), the C BRDFs in --work/c-cache.
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

import merl  # runtimes/testing (`make pyenv` installs it), as the modules below
import mitsuba_measured
import numpy as np
import out_of_family
import reference
import synthetic
import twoscale_model
from scipy.special import erf
from twoscale_c import CBrdf
from twoscale_model import TwoScaleModel

# examples/fit/render.py: its scene file of a conductor's surface, its parallel `twoscale build`, its 5 x 7 font and
# examples/mitsuba/render.py's tone map and PNG writer (Mitsuba's Bitmap: no imaging package is installed).
from examples.fit import render as fit_render

REPO = Path(__file__).resolve().parents[2]
# out_of_family's files that are members of a comparison model (a conductor coat over a Lambertian base): their BRDF is known.
KNOWN = sorted(name for name in out_of_family.MATERIALS if name.endswith("_conductor_lambert"))
MODELS = ("twoscale_conductor", "twoscale_plastic", "twoscale_subsurface", "ggx_lambert", "beckmann_lambert", "epd_lambert")
LABELS = {"measured": ("measured", "(the file)"), "twoscale_conductor": ("two-scale", "conductor"),
          "twoscale_plastic": ("two-scale", "plastic"), "twoscale_subsurface": ("two-scale", "subsurface"),
          "ggx_lambert": ("GGX", "+ Lambert"), "beckmann_lambert": ("Beckmann", "+ Lambert"), "epd_lambert": ("EPD", "+ Lambert")}
# What each compared entry's material and channels must hold.
KEYS = {"twoscale_conductor": (("beta", "p", "sigma_s", "b", "c"), ("wavelength", "eta", "k")),
        "twoscale_plastic": (("beta", "p", "sigma_s", "b", "c", "ior"), ("wavelength", "diffuse")),
        "twoscale_subsurface": (("beta", "p", "sigma_s", "b", "c", "ior", "g"), ("wavelength", "albedo")),
        "ggx_lambert": (("alpha",), ("eta", "k", "kd")), "beckmann_lambert": (("alpha",), ("eta", "k", "kd")),
        "epd_lambert": (("beta", "p"), ("eta", "k", "kd"))}


# -- the scene ------------------------------------------------------------------------------------------
def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def sky(n=120):
    """n directions of a Fibonacci lattice on the hemisphere y > 0 (y uniform: equal solid angles 2 pi / n), each
    with E = L(y) 2 pi / n, L = (0.6, 0.75, 1.0) (0.3 + 0.7 y)."""
    y = 1.0 - (np.arange(n) + 0.5) / n
    phi = np.arange(n) * math.pi * (3.0 - math.sqrt(5.0))  # the golden angle
    r = np.sqrt(1.0 - y * y)
    dirs = np.stack([r * np.cos(phi), y, r * np.sin(phi)], 1)
    return dirs, np.array([0.6, 0.75, 1.0]) * (0.3 + 0.7 * y)[:, None] * (2.0 * math.pi / n)


def lights():
    """(directions [n, 3] towards the lights, E [n, 3] RGB): the key, the rim and the sky (the module's docstring)."""
    sky_dirs, sky_e = sky()
    dirs = np.concatenate([unit([[-0.45, 0.55, 0.70], [0.5, 0.17, -0.85]]), sky_dirs])
    return dirs, np.concatenate([[[4.0, 4.0, 4.0], [3.0, 2.7, 2.2]], sky_e])


def geometry(res):
    """The sphere's pixels and every (pixel, light) pair that the light reaches: (mask [res, res], pixel index [m],
    light index [m], wi [m, 3], wo [m, 3], cos_i [m]), wi and wo in the shading frame of the pixel's normal."""
    y, x = np.mgrid[0:res, 0:res]
    x, y = 2.0 * (x + 0.5) / res - 1.0, 1.0 - 2.0 * (y + 0.5) / res
    mask = x * x + y * y < 1.0
    n = np.stack([x[mask], y[mask], np.sqrt(1.0 - x[mask] ** 2 - y[mask] ** 2)], 1)
    # Duff et al. 2017's frame (t, b, n), valid for n_z > -1: here n_z > 0.
    a = -1.0 / (1.0 + n[:, 2])
    bxy = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + n[:, 0] ** 2 * a, bxy, -n[:, 0]], 1)
    b = np.stack([bxy, 1.0 + n[:, 1] ** 2 * a, -n[:, 1]], 1)
    dirs, _ = lights()
    local = np.einsum("pij,lj->pli", np.stack([t, b, n], 1), dirs)  # [pixels, lights, 3]
    # A light within 1e-6 of the local horizon (MERL's own cut) adds nothing: cos_i ~ 0 and no sample there.
    pix, light = np.nonzero(local[..., 2] > merl.HORIZON)
    wi = local[pix, light]
    wo = np.stack([t[:, 2], b[:, 2], n[:, 2]], 1)[pix]  # the camera's +z in the frame
    return mask, pix, light, wi, wo, wi[:, 2]


def render(rho, mask, pix, light, cos_i):
    """The image [res, res, 3]: sum over the lights of E rho cos_i at each pixel, rho [3, m] at the pairs."""
    _, e = lights()
    img = np.zeros(mask.shape + (3,))
    for ch in range(3):
        img[..., ch][mask] = np.bincount(pix, weights=e[light, ch] * rho[ch] * cos_i, minlength=int(mask.sum()))
    return img


# -- the BRDFs, [3, m] at the pairs (wi, wo) ---------------------------------------------------------------
def merl_lookup(rho, wi, wo):
    """The file's rho [3, 90, 90, 180] (NaN below the horizon) trilinear in MERL's bin coordinates at (wi, wo):
    (rho [3, m], the number of points with an invalid corner, the number with no valid corner: 0 there)."""
    h = unit(wi + wo)
    theta_h = np.arccos(np.clip(h[:, 2], -1.0, 1.0))
    phi_h = np.arctan2(h[:, 1], h[:, 0])
    # The difference vector: wi rotated by -phi_h about z, then by -theta_h about y (MERL's std_coords_to_half_diff).
    c, s = np.cos(phi_h), np.sin(phi_h)
    x, y = c * wi[:, 0] + s * wi[:, 1], c * wi[:, 1] - s * wi[:, 0]
    ct, st = np.cos(theta_h), np.sin(theta_h)
    dx, dz = ct * x - st * wi[:, 2], st * x + ct * wi[:, 2]
    theta_d = np.arccos(np.clip(dz, -1.0, 1.0))
    phi_d = np.mod(np.arctan2(y, dx), math.pi)  # rho(phi_d) = rho(phi_d + pi)
    coords = [np.sqrt(theta_h / (math.pi / 2)) * 90.0, theta_d / (math.pi / 2) * 90.0, phi_d / math.pi * 180.0]
    axes = []
    for u, size, periodic in zip(coords, merl.DIMS, (False, False, True)):
        lo = np.floor(u)
        frac = u - lo
        lo = lo.astype(np.int64)
        if periodic:
            axes.append(((lo % size, 1.0 - frac), ((lo + 1) % size, frac)))
        else:  # clamped: beyond the last bin, its value
            lo, frac = np.minimum(lo, size - 1), np.where(lo >= size - 1, 0.0, frac)
            axes.append(((lo, 1.0 - frac), (np.minimum(lo + 1, size - 1), frac)))
    flat = rho.reshape(3, -1)
    total, weight = np.zeros((3, len(wi))), np.zeros(len(wi))
    broken = np.zeros(len(wi), dtype=bool)
    for i, w_i in axes[0]:
        for j, w_j in axes[1]:
            for k, w_k in axes[2]:
                v = flat[:, k + merl.DIMS[2] * (j + merl.DIMS[1] * i)]
                ok = np.isfinite(v[0])  # a sample is valid in all three channels or in none
                w = w_i * w_j * w_k
                broken |= ~ok & (w > 0.0)
                total += np.where(ok, w * v, 0.0)
                weight += np.where(ok, w, 0.0)
    empty = weight <= 0.0
    return np.where(empty, 0.0, total / np.where(empty, 1.0, weight)), int(broken.sum()), int(empty.sum())


def microfacet_lambert(entry, wi, wo):
    """rho = F(cos theta_d) D G2 / (4 cos_i cos_o) + kd / pi per channel: F the exact conductor Fresnel of eta + i k
    (out_of_family.fresnel_conductor), G2 = 1 / (1 + Lambda_i + Lambda_o) and, t = tan theta,
      GGX:      D = alpha^2 / (pi cos^4 theta_h (alpha^2 + t_h^2)^2), Lambda = (sqrt(1 + alpha^2 t^2) - 1) / 2;
      Beckmann: D = exp(-t_h^2 / alpha^2) / (pi alpha^2 cos^4 theta_h), Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a
                sqrt(pi)), a = 1 / (alpha t);
      EPD:      D = N(p) / beta^2 exp(-(t_h^2 / beta^2)^p) / cos^4 theta_h, Lambda = reference.smith_lambda(p, beta t)
                (merl.smith_lambda_at's interpolant)."""
    m = entry["material"]
    h = unit(wi + wo)
    cos_i, cos_o, cos_h = wi[:, 2], wo[:, 2], h[:, 2]
    cos_d = np.clip((wi * h).sum(1), 0.0, 1.0)
    c4, tan2_h = cos_h**4, (1.0 - cos_h * cos_h) / (cos_h * cos_h)
    tan_i, tan_o = (np.sqrt(1.0 - z * z) / z for z in (cos_i, cos_o))
    if m["model"] == "ggx_lambert":
        a2 = m["alpha"] ** 2
        d = a2 / (math.pi * c4 * (a2 + tan2_h) ** 2)
        lam_i, lam_o = (0.5 * (np.sqrt(1.0 + a2 * t * t) - 1.0) for t in (tan_i, tan_o))
    elif m["model"] == "beckmann_lambert":
        alpha = m["alpha"]
        d = np.exp(-tan2_h / alpha**2) / (math.pi * alpha**2 * c4)
        a_i, a_o = (1.0 / np.maximum(alpha * t, 1e-30) for t in (tan_i, tan_o))  # erf(a) - 1 and exp(-a^2) / a both 0 at a large
        lam_i, lam_o = (0.5 * (erf(a) - 1.0) + np.exp(-a * a) / (2.0 * a * math.sqrt(math.pi)) for a in (a_i, a_o))
    else:
        beta, p = m["beta"], m["p"]
        d = reference.norm_p(p) / beta**2 * np.exp(-np.power(tan2_h / beta**2, p)) / c4
        smith = merl.smith_lambda_at(p)
        lam_i, lam_o = smith(beta * tan_i), smith(beta * tan_o)
    coat = d / (4.0 * cos_i * cos_o * (1.0 + lam_i + lam_o))
    return np.array([out_of_family.fresnel_conductor(cos_d, c["eta"], c["k"]) * coat + c["kd"] / math.pi for c in entry["channels"]])


def twoscale_conductor(entry, tables, wi, wo):
    """F (spec + diff) of the numpy model over the general tables (the exact lobe), F reference.fresnel's."""
    m, chans = entry["material"], entry["channels"]
    # The model checks B = b / lambda over Mitsuba's 0.36-0.83 um; it is read here at the channels' wavelengths
    # only, where the fit keeps B within the tables (a b at the fit's lower bound is outside at 0.83 um).
    twoscale_model.LAMBDA_RANGE = (min(c["wavelength"] for c in chans), max(c["wavelength"] for c in chans))
    model = TwoScaleModel(tables, m["beta"], m["p"], m["sigma_s"], m["b"] or 1.0, m["c"] or 2.0, lobe="exact")
    h = unit(wi + wo)
    cos_d = np.clip((wi * h).sum(1), 0.0, 1.0)
    parts = model.eval_parts_at(wi, wo, [c["wavelength"] for c in chans])
    return np.array([reference.fresnel(cos_d, c["eta"], c["k"]) * (spec + diff) for c, (spec, diff) in zip(chans, parts)])


def layered_scene(key, entry):
    """A scene file (docs/scenes.md) of a fitted plastic or subsurface material, named `key`: the surface as
    examples/fit/render.py writes a conductor's, then model, ior, the layer's spectrum over the channels, g."""
    m, chans = entry["material"], sorted(entry["channels"], key=lambda c: c["wavelength"])
    layer = "diffuse" if key == "twoscale_plastic" else "albedo"
    text = fit_render.scene_toml({"material": {**m, "name": key}, "channels": chans})
    text += f'model = "{key.split("_")[1]}"\nior = {m["ior"]!r}\n'
    text += f'{layer} = {{ wavelengths = [{", ".join(repr(c["wavelength"]) for c in chans)}], values = [{", ".join(repr(c[layer]) for c in chans)}] }}\n'
    return text + (f'g = {m["g"]!r}\n' if layer == "albedo" else "")


# -- the fit's JSON -----------------------------------------------------------------------------------------
def check(fitted, where):
    """The JSON's `comparison` by model and its `compared`, every key this script reads present; else ValueError."""
    if "compared" not in fitted or "comparison" not in fitted:
        raise ValueError(f"{where}: no 'compared' or 'comparison' (is it from `twoscale fit --compare`?)")
    rows = {r.get("model"): r for r in fitted["comparison"]}
    for key in MODELS:
        entry = fitted["compared"].get(key)
        if entry is None or key not in rows:
            raise ValueError(f"{where}: model {key} missing from 'compared' or 'comparison'")
        mat_keys, chan_keys = KEYS[key]
        missing = [k for k in mat_keys if k not in entry.get("material", {})]
        chans = entry.get("channels", [])
        missing += [f"channels[].{k}" for k in chan_keys if len(chans) != 3 or any(k not in c for c in chans)]
        missing += [f"comparison.{k}" for k in ("parameters", "relative_rms", "log_rms") if k not in rows[key]]
        if missing:
            raise ValueError(f"{where}: {key}: no {', '.join(missing)}" + (" (or not 3 channels)" if len(chans) != 3 else ""))
    return rows


def truth(name):
    """out_of_family's material `name` (a conductor coat over a Lambertian base) as the compared entry it is a member of."""
    dist, params, (_, etas, ks), kd, _ = out_of_family.MATERIALS[name]
    material = {"model": f"{dist}_lambert", **dict(zip(("beta", "p") if dist == "epd" else ("alpha",), params))}
    return {"material": material, "channels": [{"eta": e, "k": k, "kd": d} for e, k, d in zip(etas, ks, kd)]}


# -- errors and the picture ------------------------------------------------------------------------------------
def errors(f, t):
    """(SMAPE, relative RMS) over the sphere's pixel-channels (f, t [n, 3]); SMAPE leaves out where both are 0."""
    both = (f != 0.0) | (t != 0.0)
    smape = np.mean(np.abs(f - t)[both] / ((np.abs(f) + np.abs(t))[both] / 2.0))
    return float(smape), math.sqrt(((f - t) ** 2).sum() / (t * t).sum())


def colour_of(r):
    """r in [-1, 1] as blue (-1) - white (0) - red (1)."""
    r = r[..., None]
    return np.where(r < 0, 1.0 + r * (1.0 - np.array([0.1, 0.3, 1.0])), 1.0 - r * (1.0 - np.array([1.0, 0.15, 0.1])))


def ratio_colour(f, t, mask):
    """log2(sum f / sum t) over the channels, clipped to [-1, 1] (half to twice), by colour_of; white where both are 0,
    grey off the sphere."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.clip(np.nan_to_num(np.log2(f.sum(-1) / t.sum(-1)), nan=0.0), -1.0, 1.0)
    return np.where(mask[..., None], colour_of(r), 0.25)


def legend(res, scale=2):
    """The ratio row's key: colour_of's bar from twice (top) to half (bottom)."""
    img = np.ones((res, res, 3))
    img[:, 4:4 + res // 6] = colour_of(np.linspace(1.0, -1.0, res))[:, None]
    for y, s in ((0, "x2"), ((res - 7 * scale) // 2, "x1"), (res - 7 * scale, "x1/2")):
        fit_render.text(img, 10 + res // 6, y, s, scale)
    return img


def picture(columns, lines, scale=2, gap=10, pad=8):
    """columns [(label lines, render, ratio)] side by side on white: the labels, the render, the ratio below; then the
    lines of text."""
    res = columns[0][1].shape[0]
    lh = 7 * scale + 4
    width = max(res, *(6 * scale * len(s) for c in columns for s in c[0]))
    heads = max(len(c[0]) for c in columns) * lh
    w = len(columns) * (width + gap) - gap + 2 * pad
    out = np.ones((pad + heads + 2 * (res + gap) + len(lines) * lh + pad, w, 3))
    for n, (labels, img, ratio) in enumerate(columns):
        x = pad + n * (width + gap)
        for j, s in enumerate(labels):
            fit_render.text(out, x, pad + j * lh, s, scale)
        y = pad + heads
        out[y:y + res, x:x + res] = img
        out[y + res + gap:y + 2 * res + gap, x:x + res] = ratio
    y = pad + heads + 2 * (res + gap)
    for j, line in enumerate(lines):  # at half size where a line would not fit
        fit_render.text(out, pad, y + j * lh, line, scale if 6 * scale * len(line) <= w - 2 * pad else max(1, scale // 2))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, help="a MERL file (default: out_of_family's --material, written into --work)")
    ap.add_argument("--material", default="ggx_conductor_lambert", choices=KNOWN, help="the file written when --file is not given")
    ap.add_argument("--fit", type=Path, help="the JSON of `twoscale fit FILE --compare` (default: run it)")
    ap.add_argument("--out", type=Path, default=REPO / "docs/renders/fit_compare.png")
    ap.add_argument("--res", type=int, default=64, help="the image's size (64: twoscale's render_smape)")
    ap.add_argument("--check", action="store_true", help="exit with status 2 where a model's SMAPE and the fit's render_smape differ by over 2 %%")
    ap.add_argument("--tables", type=Path, default=REPO / "tables-out", help="directory holding default/ (the general tables)")
    ap.add_argument("--work", type=Path, default=REPO / "target/tmp/fit-compare", help="the fit's output, the material folders")
    args = ap.parse_args()
    if args.res < 8:
        raise ValueError(f"--res {args.res}: at least 8")
    if args.check and args.res != 64:
        raise ValueError(f"--check compares with the fit's render_smape, rendered at 64 x 64: not with --res {args.res}")
    if not (args.tables / "default").is_dir():
        raise ValueError(f"{args.tables / 'default'}: no general tables (`make tables` builds them)")
    start = time.perf_counter()
    args.work.mkdir(parents=True, exist_ok=True)
    path = args.file or out_of_family.write(args.material, args.work)
    rgl = Path(path).read_bytes()[:12] == b"tensor_file\0"
    measured = None if rgl else merl.read(path)  # refuses a file that is not 90 x 90 x 180 MERL before anything runs

    if args.fit:
        try:
            fitted = json.loads(args.fit.read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"{args.fit}: not JSON ({e})") from None
        print(f"fit: {args.fit}")
    else:
        (args.work / "fit").mkdir(exist_ok=True)
        fitted, wall = synthetic.fit(path, args.tables, args.work / "fit", "--compare")
        print(f"fit: `twoscale fit {path} --compare`, {wall:.1f} s (its JSON in {args.work / 'fit'})")
    rows = check(fitted, args.fit or "the fit's JSON")
    if "file" in fitted and Path(fitted["file"]).name != Path(path).name:
        print(f"warning: {args.fit} is the fit of {fitted['file']}, not of {path}", file=sys.stderr)
    compared = fitted["compared"]

    t0 = time.perf_counter()
    scenes = []
    for key in ("twoscale_plastic", "twoscale_subsurface"):
        scene = args.work / "scenes" / f"{key}.toml"
        scene.parent.mkdir(exist_ok=True)
        scene.write_text(layered_scene(key, compared[key]))
        scenes.append((scene, args.work / "built" / key))
    folders = dict(zip(("twoscale_plastic", "twoscale_subsurface"), fit_render.build(scenes)))
    print(f"layered material folders: {time.perf_counter() - t0:.1f} s ({args.work / 'built'})")

    t0 = time.perf_counter()
    mask, pix, light, wi, wo, cos_i = geometry(args.res)
    if rgl:
        # BSDF::eval(si.wi = the camera's direction, wo = the light's) = rho cos_i: divided by cos_i, render() multiplies it back
        cases = [{"file": str(path), "pairs": np.concatenate([wo, wi], 1).tolist()}]
        rho = np.array(mitsuba_measured.evaluate(cases)[0]).T / cos_i
        lookups = "Mitsuba's measured plugin"
    else:
        rho, broken, empty = merl_lookup(measured, wi, wo)
        lookups = f"{broken} with a corner below the horizon (renormalised over the valid ones), {empty} with none (0)"
    imgs = {"measured": render(rho, mask, pix, light, cos_i)}
    print(f"geometry: {int(mask.sum())} sphere pixels ({int(mask.sum()) - len(np.unique(pix))} reached by no light: 0 in every render, "
          f"left out of SMAPE), {len(pix)} (pixel, light) pairs; the file's lookups: {lookups}")
    for key in MODELS:
        entry, t1 = compared[key], time.perf_counter()
        if key == "twoscale_conductor":
            rho = twoscale_conductor(entry, args.tables / "default", wi, wo)
        elif key in folders:
            brdf = CBrdf(folders[key], cache_dir=args.work / "c-cache")
            rho = np.array([brdf.eval(wi, wo, c["wavelength"]) for c in entry["channels"]])
        else:
            rho = microfacet_lambert(entry, wi, wo)
        imgs[key] = render(rho, mask, pix, light, cos_i)
        print(f"render {key}: {time.perf_counter() - t1:.1f} s")
    print(f"renders: {time.perf_counter() - t0:.1f} s at {args.res} x {args.res}")

    target = imgs["measured"][mask]
    errs = {key: errors(imgs[key][mask], target) for key in MODELS}
    print("\n| model | parameters | fit relative RMS | fit log RMS | render SMAPE | the fit's render_smape | render relative RMS |"
          "\n|---|---|---|---|---|---|---|")
    apart = []
    for key in MODELS:
        r = rows[key]
        theirs = r.get("render_smape")
        if theirs is None and args.check:
            raise RuntimeError(f"--check: {key} has no render_smape in the fit's JSON (a fit from before render_smape?)")
        if theirs is not None and args.res == 64 and abs(errs[key][0] - theirs) > 0.02 * theirs:
            apart.append(key)
        shown = "" if theirs is None else f"{theirs:.4g}"
        print(f"| {key} | {r['parameters']} | {r['relative_rms']:.4g} | {r['log_rms']:.4g} | {errs[key][0]:.4g} | {shown} | {errs[key][1]:.4g} |")
    if apart:
        print(f"warning: this render's SMAPE and the fit's render_smape differ by more than 2 % for {', '.join(apart)}", file=sys.stderr)
        if args.check:
            raise RuntimeError(f"--check: this render's SMAPE and the fit's render_smape differ by more than 2 % for {', '.join(apart)}")
    lines = [f"file: {Path(path).name}", "lights: key upper left, rim behind right (grazing), sky of 120 directions",
             "row 2: model / file, channels summed. SMAPE over the sphere, all pixels and channels"]
    if args.file is None:
        own, own_rms = errors(render(microfacet_lambert(truth(args.material), wi, wo), mask, pix, light, cos_i)[mask], target)
        print(f"\nthe file's own BRDF against its interpolated render (the interpolation's error): SMAPE {own:.4g}, relative RMS {own_rms:.4g}")
        lines.append(f"the true BRDF of the file against its interpolation: SMAPE {fit_render.pct(own)}")

    columns = [(LABELS["measured"], fit_render.tonemap(imgs["measured"]), legend(args.res))]
    columns += [(LABELS[key] + (f"SMAPE {fit_render.pct(errs[key][0])}",), fit_render.tonemap(imgs[key]),
                 ratio_colour(imgs[key], imgs["measured"], mask)) for key in MODELS]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fit_render.write_png(np.clip(picture(columns, lines), 0.0, 1.0), args.out, srgb=True)
    print(f"{args.out}: {time.perf_counter() - start:.1f} s in all")


if __name__ == "__main__":
    try:
        main()
    except (ValueError, RuntimeError, OSError) as e:  # a bad file, JSON or parameter; a failed fit or build
        print(f"compare: error: {str(e).strip().splitlines()[-1]}", file=sys.stderr)
        sys.exit(2)
