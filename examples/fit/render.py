"""One synthetic material fitted from its file, then rendered beside the target by the Mitsuba BSDF, with the error.

The material (runtimes/testing/synthetic.py, default nickel) is written as a noise-free MERL file, fitted by
`twoscale fit`, and both the fitted material (the scene file the fit wrote, eta and k from its JSON) and the target
(its true parameters and index) are built with `twoscale build --scene` and rendered by the `twoscale` BSDF: the
sphere of examples/mitsuba/render.py under its studio environment, the same seed for both. Writes target | fitted,
labelled, with the fit's relative RMS (rho cos theta_i against its file, every valid bin) and the image-space
relative RMS between the two renders over the sphere's pixels (sqrt(sum (f - t)^2 / sum t^2), all three bands).

    .venv/bin/python -m examples.fit.render --out docs/renders/fit.png [--material NAME] [--res N] [--spp N]
                                            [--tables tables-out] [--cache DIR] [--work DIR]

Wavelengths: the material folders cover 0.45-0.65 um (the fit's channels), and the BSDF reads its tables at their
edge outside (it warns so on load), so the render is spectral (llvm_ad_spectral; the BSDF has no RGB variant) on a
spectral film of three 10 nm bands inside that range, 450-460, 545-555 and 640-650 nm: the sensor samples wavelengths
in those bands only, so the warning does not apply here. The picture shows them as blue, green and red. The eta and k
spectra interpolate between the fit's three channels (450, 550, 650 nm).

Needs the default preset's general tables (`make tables`) and DRJIT_LIBLLVM_PATH (the Makefile exports it); the
target is cached in target/tmp/merl-cache (the first run computes it by brute force: a few minutes), and the material
folders are kept in target/tmp/fit-render (their first build takes some 10-20 s each).
"""
import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mitsuba as mi
import numpy as np

REPO = Path(__file__).resolve().parents[2]
mi.set_variant("llvm_ad_spectral")

import merl  # noqa: E402  (runtimes/testing: `make pyenv` installs it, as synthetic and twoscale_c)
import synthetic  # noqa: E402
import twoscale_mitsuba  # noqa: E402  (registers the plugin)
from twoscale_c import twoscale_binary  # noqa: E402

# examples/mitsuba/render.py: its scene (the sphere on the checkered ground, the studio environment) and PNG writer.
from examples.mitsuba.render import scene, tonemap, write_png  # noqa: E402

# The film's bands (nm), inside the folders' 450-650 nm; shown as blue, green, red.
BANDS = ((450.0, 460.0), (545.0, 555.0), (640.0, 650.0))


# -- the materials --------------------------------------------------------------------------------
def target_result(name):
    """The true material in the shape of the fit's JSON (material, channels)."""
    beta, p, sigma_s, b, c, index = synthetic.MATERIALS[name]
    m = {"name": name, "beta": beta, "p": p, "sigma_s": sigma_s}
    if sigma_s > 0:
        m.update(b=b, c=c)
    channels = [{"channel": col, "wavelength": lam, "eta": eta, "k": k}
                for col, lam, (eta, k) in zip(("red", "green", "blue"), synthetic.LAMBDAS, index)]
    return {"material": m, "channels": channels}


def scene_toml(result):
    """A scene file of one conductor (docs/scenes.md)."""
    m = result["material"]
    t = f'[[material]]\nname = "{m["name"]}"\nbeta = {m["beta"]!r}\np = {m["p"]!r}\n'
    if m["sigma_s"] > 0:
        lams = sorted(c["wavelength"] for c in result["channels"])
        t += f'sigma_s = {m["sigma_s"]!r}\nb = {m["b"]!r}\nc = {m["c"]!r}\nwavelengths = [{", ".join(map(repr, lams))}]\n'
    return t


def build(jobs):
    """`twoscale build --scene` of each (scene file, out) at once (a build is mostly one thread): the material folders."""
    cmds = [[twoscale_binary(), "build", "--quiet", "--scene", str(scene_file), "--out", str(out)] for scene_file, out in jobs]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for cmd in cmds]
    folders = []
    for cmd, proc, (_, out) in zip(cmds, procs, jobs):
        _, err = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: {err.strip()}")
        found = sorted(d.parent for d in Path(out).rglob("epd_g1.manifest.json"))
        if len(found) != 1:
            raise RuntimeError(f"{out}: expected one material folder, found {len(found)}")
        folders.append(found[0])
    return folders


def bsdf(folder, result):
    """The twoscale BSDF of a material folder, eta and k as spectra through the channels (nm, ascending)."""
    chans = sorted(result["channels"], key=lambda c: c["wavelength"])
    spec = {q: {"type": "spectrum", "value": [(c["wavelength"] * 1e3, c[q]) for c in chans]} for q in ("eta", "k")}
    return {"type": "twoscale", "tables": str(folder), **spec}


# -- rendering --------------------------------------------------------------------------------------
def film(res):
    def band(lo, hi):
        return {"type": "spectrum", "value": [(lo, 0.0), (lo + 0.01, 1.0), (hi - 0.01, 1.0), (hi, 0.0)]}
    bands = {f"b{int(lo)}": band(lo, hi) for lo, hi in BANDS}
    return {"type": "specfilm", "width": res, "height": res, "rfilter": {"type": "box"}, **bands}


def render(d, seed):
    """(radiance [res, res, 3] in the order of BANDS, seconds of the render with kernel compilation, the scene). The
    film integrates over wavelength (nm): divided by each band's width, a band reads as radiance."""
    s = mi.load_dict(d)
    t0 = time.time()
    img = np.asarray(mi.render(s, seed=seed), dtype=np.float64) / np.array([hi - lo - 0.01 for lo, hi in BANDS])
    return img, time.time() - t0, s


def sphere_mask(s, res):
    """The pixels whose centre sees the sphere (radius 1 at the origin): the camera's rays against it."""
    y, x = np.mgrid[0:res, 0:res]
    pos = mi.Point2f(((x.ravel() + 0.5) / res).astype(np.float32), ((y.ravel() + 0.5) / res).astype(np.float32))
    ray, _ = s.sensors()[0].sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    def points(v):
        return np.stack([np.broadcast_to(np.asarray(c, dtype=np.float64), (res * res,)) for c in (v.x, v.y, v.z)], axis=1)
    o, d = points(ray.o), points(ray.d)
    d /= np.linalg.norm(d, axis=1)[:, None]
    od = (o * d).sum(1)
    disc = od ** 2 - ((o * o).sum(1) - 1.0)
    return ((disc > 0) & (-od - np.sqrt(np.maximum(disc, 0)) > 0)).reshape(res, res)


# -- the picture ------------------------------------------------------------------------------------
# A 5 x 7 pixel font (rows top to bottom, 5 bits each, the leftmost the highest): the labels, upper case.
FONT = {
    "A": "0E11111F111111", "B": "1E11111E11111E", "C": "0E11101010110E", "D": "1E11111111111E", "E": "1F10101E10101F",
    "F": "1F10101E101010", "G": "0E11101711110F", "H": "1111111F111111", "I": "0E04040404040E", "J": "0702020202120C",
    "K": "11121418141211", "L": "1010101010101F", "M": "111B1515111111", "N": "11111915131111", "O": "0E11111111110E",
    "P": "1E11111E101010", "Q": "0E11111115120D", "R": "1E11111E141211", "S": "0F10100E01011E", "T": "1F040404040404",
    "U": "1111111111110E", "V": "11111111110A04", "W": "1111111515150A", "X": "11110A040A1111", "Y": "1111110A040404",
    "Z": "1F01020408101F", "0": "0E11131519110E", "1": "040C040404040E", "2": "0E11010204081F", "3": "1F02040201110E",
    "4": "02060A121F0202", "5": "1F101E0101110E", "6": "0608101E11110E", "7": "1F010204080808", "8": "0E11110E11110E",
    "9": "0E11110F01020C", " ": "00000000000000", ".": "00000000000C0C", ",": "000000000C0408", ":": "000C0C000C0C00",
    "%": "18190204081303", "=": "00001F001F0000", "(": "02040808080402", ")": "08040202020408", "-": "0000001F000000",
    "+": "0004041F040400", "/": "00010204081000", "|": "04040404040404", "_": "0000000000001F",
}


def text(img, x, y, s, scale=2, colour=(0.0, 0.0, 0.0)):
    """Draws s (upper-cased) into img [h, w, 3] with its top left corner at (x, y)."""
    for ch in s.upper():
        rows = FONT.get(ch, FONT[" "])
        for r in range(7):
            bits = int(rows[2 * r:2 * r + 2], 16)
            for col in range(5):
                if bits & (0x10 >> col):
                    img[y + r * scale:y + (r + 1) * scale, x + col * scale:x + (col + 1) * scale] = colour
        x += 6 * scale


def picture(panels, labels, lines, gap=6, pad=8, scale=2):
    """The panels side by side on white, a label above each, the lines of text below."""
    h, w = panels[0].shape[:2]
    lh = 7 * scale + pad
    width = len(panels) * w + (len(panels) - 1) * gap
    out = np.ones((pad + lh + h + pad + len(lines) * lh, width, 3))
    for i, (p, label) in enumerate(zip(panels, labels)):
        x = i * (w + gap)
        text(out, x + 2, pad, label, scale)
        out[pad + lh:pad + lh + h, x:x + w] = p
    for j, line in enumerate(lines):  # at half size where a line would not fit
        text(out, 2, pad + lh + h + pad + j * lh, line, scale if 6 * scale * len(line) <= width - 2 else max(1, scale // 2))
    return out


def pct(x):
    return f"{100 * x:.3g}%"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=REPO / "docs/renders/fit.png")
    ap.add_argument("--material", default="nickel", choices=sorted(synthetic.MATERIALS))
    ap.add_argument("--tables", type=Path, default=REPO / "tables-out", help="directory holding default/ (the general tables)")
    ap.add_argument("--cache", type=Path, default=REPO / "target/tmp/merl-cache")
    ap.add_argument("--work", type=Path, default=REPO / "target/tmp/fit-render", help="where the material folders are built")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    name = args.material

    t0 = time.perf_counter()
    rho = synthetic.target(name, args.cache)
    print(f"target {name}: {time.perf_counter() - t0:.1f} s (cached in {args.cache})")
    with tempfile.TemporaryDirectory(prefix="twoscale-fit-render-") as tmp:
        tmp = Path(tmp)
        path = tmp / f"{name}.binary"
        merl.write(path, rho)
        (tmp / "fit").mkdir()
        fitted, wall = synthetic.fit(path, args.tables, tmp / "fit", "--model", "conductor")
        fit_rms = fitted["error"]["relative_rms"]
        print(f"fit: {wall:.1f} s ({fitted['seconds']:.1f} s by its own count); relative RMS {fit_rms:.3g}; "
              + ", ".join(f"{k} {t:g} -> {g:.4g}" for k, t, g in synthetic.recovered(name, fitted)))

        # The folders persist in --work: `twoscale build` rebuilds a material only when its parameters change.
        truth = target_result(name)
        work = args.work / name
        (work / "target").mkdir(parents=True, exist_ok=True)
        (work / "target" / f"{name}.toml").write_text(scene_toml(truth))
        t0 = time.perf_counter()
        folders = dict(zip(("target", "fitted"), build([(work / "target" / f"{name}.toml", work / "target"),
                                                         (tmp / "fit" / f"{name}.toml", work / "fitted")])))
        print(f"material folders: {time.perf_counter() - t0:.1f} s ({work})")

        imgs, mask = {}, None
        for key, result in (("target", truth), ("fitted", fitted)):
            imgs[key], secs, s = render(scene(bsdf(folders[key], result), film(args.res), args.spp), seed=0)
            print(f"render {key}: {args.res} x {args.res}, {args.spp} spp, 3 bands, {secs:.1f} s")
            if mask is None:
                mask = sphere_mask(s, args.res)
        print(f"(a warning above that a folder covers 0.45-0.65 um does not apply: the film samples "
              f"{', '.join(f'{lo:g}-{hi:g}' for lo, hi in BANDS)} nm only)")

    t, f = imgs["target"][mask], imgs["fitted"][mask]
    img_rms = math.sqrt(((f - t) ** 2).sum() / (t * t).sum())
    per_band = [math.sqrt(((f[:, j] - t[:, j]) ** 2).sum() / (t[:, j] ** 2).sum()) for j in range(3)]
    panels = [tonemap(imgs[k][..., ::-1]) for k in ("target", "fitted")]  # the bands as R, G, B
    labels = [f"target: {name}", "fitted from its file"]
    lines = [f"fit: relative RMS {pct(fit_rms)} (rho cos)",
             f"renders: relative RMS {pct(img_rms)} (sphere)",
             "bands 455 | 550 | 645 nm as B | G | R"]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_png(np.clip(picture(panels, labels, lines), 0, 1), args.out, srgb=True)
    print(f"fit relative RMS (rho cos theta_i against its file, every valid bin): {pct(fit_rms)}")
    print(f"image relative RMS (target vs fitted, the same seed, {int(mask.sum())} sphere pixels, all bands): {pct(img_rms)} "
          f"(bands {' | '.join(f'{lo:g}-{hi:g} nm {pct(e)}' for (lo, hi), e in zip(BANDS, per_band))})")
    print(f"{args.out}: {time.perf_counter() - start:.1f} s in all")


if __name__ == "__main__":
    try:
        main()
    except (twoscale_mitsuba.TwoScaleError, RuntimeError) as e:  # Mitsuba re-raises a plugin's error with its traceback
        print(f"render: error: {str(e).strip().splitlines()[-1]}", file=sys.stderr)
        sys.exit(1)
