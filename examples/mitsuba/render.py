"""The pictures of the `twoscale` Mitsuba BSDF (`make renders`), written as PNG into --out.

One scene: a sphere on a checkered ground plane under a studio environment map (a soft sky, two
bright windows and a small sun), path traced in llvm_ad_spectral in the default symbolic mode.

  bands.png         the sphere at three 10 nm bands around 450, 550 and 650 nm (one render, a
                    spectral film): the diffraction halo about the highlights widens with wavelength;
  fit_vs_exact.png  lobe = "fit" | lobe = "exact" | false-colour relative difference, 550 nm band;
  nickel.png        the nickel of examples/scenes/merl_nickel.toml with Palik's Ni index, sRGB;
  b_sweep.png       one gold surface at b = 0.5, 2 and 8 um, sRGB;
  models.png        the material models: the nickel (a conductor), red_plastic (a plastic) and alumina (a
                    subsurface medium), sRGB;
  textured.png      general mode (--tables, the default preset): a gold sphere whose beta and sigma_s are
                    bitmaps, a polished patch, three scratches and a worn band, sRGB.

    python -m examples.mitsuba.render --materials DIR/scene-render_materials --out docs/renders [--tables tables-out/default]
                      [--res N] [--spp N] [--only NAME]

DIR/scene-render_materials is `twoscale build --scene examples/mitsuba/render_materials.toml`. Prints
each picture's render time and roughconductor's on the same scene (2 threads when run by `make renders`).
"""
import argparse
import math
import sys
import time
from pathlib import Path

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_spectral")

import twoscale_mitsuba  # noqa: E402  (registers the plugin)

IOR = Path(mi.__file__).parent / "data/ior"


def conductor(metal):
    return {"eta": {"type": "spectrum", "filename": str(IOR / f"{metal}.eta.spd")},
            "k": {"type": "spectrum", "filename": str(IOR / f"{metal}.k.spd")}}


def band(c):
    return {"type": "spectrum", "value": [(c - 5.5, 0.0), (c - 5.0, 1.0), (c + 5.0, 1.0), (c + 5.5, 0.0)]}


def studio(w=512):
    """A lat-long environment: a soft sky over a dark floor, two bright window strips and a small sun."""
    h = w // 2
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi
    up = np.cos(theta)[:, None, None]
    sky = np.where(up > 0, 0.2 + 0.4 * up * np.array([0.8, 0.9, 1.0]), 0.03 * np.array([1.0, 0.9, 0.8]))
    img = np.broadcast_to(sky, (h, w, 3)).copy()
    dphi = lambda p0: np.abs(((phi - p0 + math.pi) % (2 * math.pi)) - math.pi)  # noqa: E731
    for p0 in (0.9, 4.2):
        img[(dphi(p0) < 0.2) & (np.abs(theta - 1.15) < 0.3)[:, None]] = 5.0
    img[(dphi(2.4)[None, :] ** 2 + (theta[:, None] - 0.75) ** 2) < 0.05 ** 2] = 80.0
    return mi.Bitmap(img.astype(np.float32))


ENV = None


def scene(bsdf, film, spp):
    """The sphere (radius 1) on the ground plane y = -1, the camera looking slightly down at it."""
    global ENV
    if ENV is None:
        ENV = studio()
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 30,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0.9, 5.2], target=[0, -0.15, 0], up=[0, 1, 0]),
                   "film": film, "sampler": {"type": "independent", "sample_count": spp}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "ground": {"type": "rectangle",
                   "to_world": mi.ScalarTransform4f().translate([0, -1, 0]).rotate([1, 0, 0], -90).scale(8),
                   "bsdf": {"type": "diffuse", "reflectance": {
                       "type": "checkerboard", "color0": 0.15, "color1": 0.45,
                       "to_uv": mi.ScalarTransform4f().scale([8, 8, 1])}}},
        "env": {"type": "envmap", "bitmap": ENV, "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], 30)},
    }


def rgb_film(res):
    return {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "gaussian"}, "pixel_format": "rgb"}


def render(d, seed=0):
    """(image, seconds): the scene is loaded first, so the time is the render's (kernel compilation
    included, as a user's first render sees it)."""
    s = mi.load_dict(d)
    t0 = time.time()
    img = np.asarray(mi.render(s, seed=seed), dtype=np.float64)
    return img, time.time() - t0


# Colour maps: piecewise-linear through a few anchors (inferno-like; blue-white-red diverging).
SEQ = np.array([[0, 0, 4], [40, 11, 84], [101, 21, 110], [159, 42, 99], [212, 72, 66], [245, 125, 21], [250, 193, 39], [252, 255, 164]]) / 255
DIV = np.array([[33, 102, 172], [146, 197, 222], [247, 247, 247], [244, 165, 130], [178, 24, 43]]) / 255


def cmap(x, anchors):
    x = np.clip(x, 0, 1) * (len(anchors) - 1)
    i = np.minimum(x.astype(int), len(anchors) - 2)
    t = (x - i)[..., None]
    return anchors[i] * (1 - t) + anchors[i + 1] * t


def log_false_colour(img, lo, hi):
    """log10 of the radiance mapped from [lo, hi] (decades) onto the sequential map."""
    with np.errstate(divide="ignore"):
        return cmap((np.log10(np.maximum(img, 1e-30)) - lo) / (hi - lo), SEQ)


def write_png(rgb, path, srgb=False):
    """rgb in [0, 1]: display-encoded already, or linear and sRGB-encoded here."""
    bmp = mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=srgb).write(str(path))


def tonemap(img):
    return img / (1.0 + img)  # Reinhard; sRGB encoding by write_png


def strip(panels, gap=6):
    h = panels[0].shape[0]
    out = [panels[0]]
    for p in panels[1:]:
        out += [np.ones((h, gap, 3)), p]
    return np.concatenate(out, axis=1)


def surface_maps(w=1024, h=512):
    """beta and sigma_s (um) over a sphere's (u, v), as one-channel bitmaps (row 0 at v = 0): a brushed-metal base
    (beta 0.12, sigma_s 0.01), a worn band below the equator (beta 0.3), a polished patch (beta 0.015, no roughness
    at the diffraction scale) and three scratches (beta 0.05, sigma_s 0.08: diffraction halos)."""
    v, u = np.mgrid[0:h, 0:w]
    u, v = (u + 0.5) / w, (v + 0.5) / h
    beta = np.full((h, w), 0.12)
    sigma_s = np.full((h, w), 0.01)
    band = np.clip(1.0 - np.abs(v - 0.56) / 0.05, 0.0, 1.0) ** 0.5
    beta = beta + (0.3 - beta) * band
    patch = np.clip((0.1 - np.hypot((u - 0.7) * 2.0, v - 0.4)) / 0.01, 0.0, 1.0)  # a disk, 1 % soft edge
    beta, sigma_s = beta + (0.015 - beta) * patch, sigma_s * (1.0 - patch)
    for u0, slope in ((0.77, 0.9), (0.83, -1.3), (0.87, 0.4)):
        line = np.abs((u - u0) - slope * (v - 0.42) / 2.0) < 0.0025
        line &= np.abs(v - 0.42) < 0.14
        beta, sigma_s = np.where(line, 0.05, beta), np.where(line, 0.08, sigma_s)
    return {k: mi.Bitmap(x.astype(np.float32)[..., None]) for k, x in (("beta", beta), ("sigma_s", sigma_s))}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", required=True, help="the scene folder of examples/mitsuba/render_materials.toml")
    ap.add_argument("--out", required=True)
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--tables", default="tables-out/default", help="the default preset's folder (general mode)")
    ap.add_argument("--only", help="one picture's name (its file stem), e.g. textured")
    args = ap.parse_args()
    out, mats, res, spp = Path(args.out), Path(args.materials), args.res, args.spp
    out.mkdir(parents=True, exist_ok=True)

    def ts(name, **kw):
        return {"type": "twoscale", "tables": str(mats / name), **kw}

    # 6. Spatially varying: general mode, beta and sigma_s as textures over the sphere.
    if args.only in (None, "textured"):
        maps = surface_maps()
        bsdf = {"type": "twoscale", "tables": args.tables, "p": 1.2, "b": 1.5, "c": 2.2, **conductor("Au"),
                **{k: {"type": "bitmap", "bitmap": bmp, "raw": True} for k, bmp in maps.items()}}
        d = scene(bsdf, rgb_film(res), spp)
        d["sphere"]["to_world"] = mi.ScalarTransform4f().rotate([1, 0, 0], -90)  # the pole up, u = 0.75 facing the camera
        img, secs = render(d)
        write_png(tonemap(img), out / "textured.png", srgb=True)
        print(f"textured.png: gold in general mode, beta and sigma_s bitmaps, {res} x {res}, {spp} spp, {secs:.1f} s")
    if args.only is not None:
        return

    # roughconductor on the same scene: Beckmann (the EPD at p = 1) at the nickel's beta.
    _, secs = render(scene({"type": "roughconductor", "distribution": "beckmann", "alpha": 0.03, **conductor("Ni_palik")},
                           rgb_film(res), spp))
    print(f"roughconductor (Beckmann, alpha 0.03, Ni): {res} x {res}, {spp} spp, {secs:.1f} s")

    # 1. Three narrow bands in one render (a spectral film), each on its own scale.
    film = {"type": "specfilm", "width": res, "height": res, "rfilter": {"type": "box"},
            "b450": band(450), "b550": band(550), "b650": band(650)}
    img, secs = render(scene(ts("bands", fresnel="one"), film, spp))
    write_png(strip([cmap(np.sqrt(img[..., j] / np.percentile(img[..., j], 99.9)), SEQ) for j in range(3)]), out / "bands.png")
    print(f"bands.png: 3 bands of {res} x {res}, {spp} spp (one render), {secs:.1f} s")

    # 2. Fit against exact at 550 nm, the same seed for both: their difference is the lobe's.
    film = {"type": "specfilm", "width": res, "height": res, "rfilter": {"type": "box"}, "b550": band(550)}
    (fit, t_fit), (exact, t_exact) = (render(scene(ts("halo", fresnel="one", lobe=lobe), film, spp)) for lobe in ("fit", "exact"))
    fit, exact = fit[..., 0], exact[..., 0]
    hi = math.log10(np.percentile(exact, 99.9))
    # Where the sphere's diffraction dominates: pixels whose fit and exact differ beyond the noise of
    # the ground's diffuse light (same seed: the ground renders identically).
    mask = np.abs(fit - exact) > 1e-6 * np.maximum(exact, 1e-30)
    rel = np.where(mask, (fit - exact) / np.where(exact > 0, exact, 1.0), 0.0)
    diff = np.where(mask[..., None], cmap(0.5 + rel / 0.8, DIV), 0.0)  # -40 % .. +40 %
    write_png(strip([log_false_colour(fit, hi - 4, hi), log_false_colour(exact, hi - 4, hi), diff]), out / "fit_vs_exact.png")
    print(f"fit_vs_exact.png: 550 nm band, {res} x {res}, {spp} spp each: fit {t_fit:.1f} s, exact {t_exact:.1f} s; "
          f"(fit - exact) / exact over the pixels where they differ: 5-95 % [{np.percentile(rel[mask], 5):+.1%}, "
          f"{np.percentile(rel[mask], 95):+.1%}] (colour scale -40 % blue .. +40 % red)")

    # 3. Nickel, full spectrum to sRGB.
    img, secs = render(scene(ts("nickel", **conductor("Ni_palik")), rgb_film(res), spp))
    write_png(tonemap(img), out / "nickel.png", srgb=True)
    print(f"nickel.png: {res} x {res}, {spp} spp, full spectral, {secs:.1f} s")

    # 4. One gold surface at three correlation lengths.
    panels, times = [], []
    for name in ("b0.5", "b2", "b8"):
        img, secs = render(scene(ts(name, **conductor("Au")), rgb_film(res), spp))
        panels.append(tonemap(img))
        times.append(f"{secs:.1f} s")
    write_png(strip(panels), out / "b_sweep.png", srgb=True)
    print(f"b_sweep.png: gold, b = 0.5 | 2 | 8 um, {res} x {res}, {spp} spp each: {' | '.join(times)}")

    # 5. The material models (docs/maths.md sections 7, 10 and 11): the conductor, a plastic, a subsurface medium.
    panels, times = [], []
    for bsdf in (ts("nickel", **conductor("Ni_palik")), ts("red_plastic"), ts("alumina")):
        img, secs = render(scene(bsdf, rgb_film(res), spp))
        panels.append(tonemap(img))
        times.append(f"{secs:.1f} s")
    write_png(strip(panels), out / "models.png", srgb=True)
    print(f"models.png: nickel (conductor) | red_plastic (plastic) | alumina (subsurface), {res} x {res}, {spp} spp each: {' | '.join(times)}")


if __name__ == "__main__":
    try:
        main()
    except (twoscale_mitsuba.TwoScaleError, RuntimeError) as e:  # Mitsuba re-raises a plugin's error with its traceback
        print(f"render: error: {str(e).strip().splitlines()[-1]}", file=sys.stderr)
        sys.exit(1)
