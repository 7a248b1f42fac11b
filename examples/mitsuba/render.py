#!/usr/bin/env python3
"""The pictures of the `twoscale` Mitsuba plugin (`make renders`), written as PNG into --out:

  bands.png         one sphere at narrow bands (10 nm) around 450, 550 and 650 nm, log false colour:
                    the diffraction halo about the highlight widens with wavelength;
  fit_vs_exact.png  lobe = "fit" | lobe = "exact" (zh_lobe; without it, C evaluated directly by
                    reference.py on a dense (u, theta_h) grid) | false-colour relative difference;
  nickel.png        a full spectral render of a nickel-like conductor (Palik's Ni index).

    python3 render.py --tables tables-out/default --out docs/renders [--spp N] [--res N]

Prints the sample counts, resolutions and render times. llvm_ad_spectral, evaluated (wavefront) loops.
"""
import argparse
import math
import sys
import time
from pathlib import Path

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_spectral")

# This folder's modules (run as a script, its folder is on the import path).
import reference  # noqa: E402
import twoscale_bsdf  # noqa: E402
from twoscale_model import TwoScaleError, TwoScaleModel  # noqa: E402

# Shown in the pictures of the lobe: a sharp microfacet peak (beta = 0.02) and a diffraction halo
# of angular width ~ lambda / (2 b) (B = b / lambda = 13 at 450 nm, 9 at 650 nm) carrying
# 1 - A ~ 30 % of the energy at 550 nm.
HALO = dict(beta=0.02, p=1.0, sigma_s=0.03, b=6.0, c=2.0)
# The bands picture: sigma_s = 0.1 um puts 1 - A > 97 % of the energy in the halo at every band, so
# the three halos carry the same energy and differ by their width alone; b = 1.5 um makes that width
# (~ lambda / (2 b) rad) span many pixels of the sphere.
BANDS = dict(HALO, sigma_s=0.1, b=1.5)
NICKEL = dict(beta=0.03, p=0.9, sigma_s=0.004, b=0.8, c=2.3)  # examples/scenes/merl_nickel.toml


def band(c):
    return {"type": "spectrum", "value": [(c - 5.5, 0.0), (c - 5.0, 1.0), (c + 5.0, 1.0), (c + 5.5, 0.0)]}


def studio(w=128):
    """A lat-long environment: a soft sky over a dark floor, with two bright window strips."""
    h = w // 2
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi
    up = np.cos(theta)[:, None, None]
    sky = np.where(up > 0, 0.25 + 0.5 * up * np.array([0.8, 0.9, 1.0]), 0.04 * np.array([1.0, 0.9, 0.8]))
    img = np.broadcast_to(sky, (h, w, 3)).copy()
    for p0 in (0.9, 4.2):
        win = (np.abs(((phi - p0 + math.pi) % (2 * math.pi)) - math.pi) < 0.25) & (np.abs(theta - 1.1) < 0.35)[:, None]
        img[win] = 6.0
    return mi.Bitmap(img.astype(np.float32))


def scene(bsdf, film, spp, light_at=(1.2, 0.8, 6.0), env=None):
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": 28,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4.5], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": film, "sampler": {"type": "independent", "sample_count": spp}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "light": {"type": "point", "position": list(light_at), "intensity": {"type": "uniform", "value": 40.0}},
    }
    if env is not None:
        d["env"] = {"type": "envmap", "bitmap": env}
    return d


def render(d):
    t0 = time.time()
    img = np.asarray(mi.render(mi.load_dict(d)), dtype=np.float64)
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
    """log10 of the radiance mapped from [lo, hi] (decades) onto the sequential map; background black."""
    with np.errstate(divide="ignore"):
        return cmap((np.log10(np.maximum(img, 1e-30)) - lo) / (hi - lo), SEQ)


def write_png(rgb, path):
    """rgb in [0, 1], already display-encoded."""
    bmp = mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=False).write(str(path))


def strip(panels, gap=4):
    h = panels[0].shape[0]
    out = [panels[0]]
    for p in panels[1:]:
        out += [np.ones((h, gap, 3)), p]
    return np.concatenate(out, axis=1)


class DirectLobeModel(TwoScaleModel):
    """lobe_c from reference.lobe_c (the direct 2-D integral, no table) on a dense grid in (u, theta_h)
    for one wavelength, interpolated linearly in (u, theta_h) on ln C."""

    def __init__(self, tables, lam, nu=24, nt=160, **kw):
        super().__init__(tables, **kw)
        from scipy.interpolate import RegularGridInterpolator

        self.grid_u = np.linspace(0.0, self.b / lam, nu)
        self.grid_t = np.concatenate([[0.0], np.geomspace(1e-3, math.pi / 2, nt - 1)])
        c = np.array([[reference.lobe_c(t, u, self.c, self.p, self.beta) for t in self.grid_t] for u in self.grid_u])
        self.interp = RegularGridInterpolator((self.grid_u, self.grid_t), np.log(np.maximum(c, 1e-300)))

    def lobe_c(self, u, cos_h):
        th = np.arccos(np.clip(cos_h, 0.0, 1.0))
        u = np.clip(u, self.grid_u[0], self.grid_u[-1])
        return np.exp(self.interp(np.stack(np.broadcast_arrays(u, th), axis=-1)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tables", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--res", type=int, default=160)
    ap.add_argument("--spp", type=int, default=32)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    twoscale_bsdf.register()
    twoscale_bsdf.jit_wavefront()
    tables = str(Path(args.tables))
    res, spp = args.res, args.spp
    halo = {"type": "twoscale", "tables": tables, "fresnel": "one", **HALO}

    # 1. Narrow bands: one render, three 10 nm channels of a spectral film.
    film = {"type": "specfilm", "width": res, "height": res, "rfilter": {"type": "box"},
            "b450": band(450), "b550": band(550), "b650": band(650)}
    img, secs = render(scene({**halo, **BANDS}, film, 2 * spp))
    # Each band on its own scale: sqrt of the radiance over its 99.9th percentile.
    write_png(strip([cmap(np.sqrt(img[..., j] / np.percentile(img[..., j], 99.9)), SEQ) for j in range(3)]), out / "bands.png")
    widths = []
    for j in range(3):
        # The radius holding half of the image's radiance, about its brightest (5 x 5 averaged) point.
        k = np.ones(5) / 5
        blur = np.apply_along_axis(np.convolve, 0, np.apply_along_axis(np.convolve, 1, img[..., j], k, "same"), k, "same")
        y, x = np.unravel_index(np.argmax(blur), blur.shape)
        yy, xx = np.indices(blur.shape)
        r = np.hypot(yy - y, xx - x).ravel()
        order = np.argsort(r)
        cum = np.cumsum(img[..., j].ravel()[order])
        widths.append(r[order][np.searchsorted(cum, 0.5 * cum[-1])])
    print(f"bands.png: 3 x {res} x {res}, {2 * spp} spp (one render, 3 channels), {secs:.1f} s; "
          f"radius holding half the radiance at 450 / 550 / 650 nm: {widths[0]:.1f} / {widths[1]:.1f} / {widths[2]:.1f} px")

    # 2. Fit against exact at 550 nm.
    lobe_table = (Path(tables) / "zh_lobe.h5").exists()
    film = {"type": "specfilm", "width": res, "height": res, "rfilter": {"type": "box"}, "b550": band(550)}
    fit_bsdf = mi.load_dict({**halo, "lobe": "fit"})
    if lobe_table:
        exact_bsdf, label = mi.load_dict({**halo, "lobe": "exact"}), "exact (zh_lobe)"
    else:
        exact_bsdf = mi.load_dict({**halo, "lobe": "fit"})
        t0 = time.time()
        exact_bsdf.model = DirectLobeModel(fit_bsdf.model.t, 0.55, **HALO)
        label = f"direct C (reference.lobe_c grid, {time.time() - t0:.1f} s to tabulate)"
    imgs, times = [], []
    for b in (fit_bsdf, exact_bsdf):
        # The same sampler seed for both: their difference is the lobe's, not noise's alone.
        im, secs = render(scene(b, film, spp))
        imgs.append(im[..., 0])
        times.append(secs)
    fit, exact = imgs
    hi = math.log10(np.percentile(exact, 99.9))
    mask = exact > 10 ** (hi - 4)
    rel = np.where(mask, (fit - exact) / np.where(mask, exact, 1.0), 0.0)
    diff = np.where(mask[..., None], cmap(0.5 + rel / 0.8, DIV), 0.0)  # -40 % .. +40 %
    write_png(strip([log_false_colour(fit, hi - 4, hi), log_false_colour(exact, hi - 4, hi), diff]), out / "fit_vs_exact.png")
    med = np.median(np.abs(rel[mask]))
    print(f"fit_vs_exact.png: 550 nm, {res} x {res}, {spp} spp, fit {times[0]:.1f} s, {label} {times[1]:.1f} s; "
          f"relative difference (fit - exact) / exact: median |.| {med:.1%}, 5-95 % [{np.percentile(rel[mask], 5):+.1%}, "
          f"{np.percentile(rel[mask], 95):+.1%}] (colour scale -40 % blue .. +40 % red)")

    # 3. Nickel, full spectrum to sRGB.
    nickel = {"type": "twoscale", "tables": tables, **NICKEL,
              "eta": {"type": "spectrum", "filename": str(Path(mi.__file__).parent / "data/ior/Ni_palik.eta.spd")},
              "k": {"type": "spectrum", "filename": str(Path(mi.__file__).parent / "data/ior/Ni_palik.k.spd")}}
    film = {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "gaussian"}, "pixel_format": "rgb"}
    img, secs = render(scene(nickel, film, spp * 2, light_at=(2.5, 2.0, 5.0), env=studio()))
    rgb = img / (1.0 + img)  # Reinhard, then sRGB encoding by the bitmap conversion below
    bmp = mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(out / "nickel.png"))
    print(f"nickel.png: {res} x {res}, {spp * 2} spp, full spectral (llvm_ad_spectral), {secs:.1f} s")


if __name__ == "__main__":
    try:
        main()
    except (TwoScaleError, RuntimeError) as e:  # Mitsuba re-raises a plugin's error with its traceback: say its last line
        print(f"render: error: {str(e).strip().splitlines()[-1]}", file=sys.stderr)
        sys.exit(1)
