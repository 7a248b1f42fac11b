"""Throughput of the `twoscale` BSDF against Mitsuba's own `roughconductor` (and, for the plastic model,
`roughplastic`), side by side in one run.

The scene of render.py (a sphere on a ground plane under an environment map, path traced, max depth
4) with the sphere made of: twoscale lobe = "exact", twoscale lobe = "fit", twoscale lobe = "exact" with
energy = "compensated" (the nickel of render_materials.toml, Palik's Ni index), and roughconductor (Beckmann, alpha = beta = 0.03, the same
index), the same nickel in general mode (the default preset's tables at its parameters, both lobes); and
red_plastic of render_materials.toml (docs/maths.md section 10) against roughplastic
(Beckmann, alpha = beta = 0.08, int_ior 1.5, nonlinear, the same diffuse spectrum). llvm_ad_spectral,
default symbolic mode. Each is rendered once to compile its kernels, then
--repeat times interleaved with the others; the median time gives the throughput (samples per
second) and the ratio to roughconductor's. A render's cost depends on the paths each BSDF samples
(how many continue, what they hit), so the BSDF calls are timed alone as well: sample() then
eval_pdf() at the sampled direction over --lanes random (wi, sample) in one kernel, the same
random numbers for every BSDF.

    python -m examples.mitsuba.bench --materials DIR/scene-render_materials [--tables tables-out/default] [--res 256] [--spp 64] [--repeat 5]
"""
import argparse
import json
import statistics
import time
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_spectral")

from examples.mitsuba import render  # noqa: E402  (this folder's scene)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", required=True, help="the scene folder of examples/mitsuba/render_materials.toml")
    ap.add_argument("--tables", default="tables-out/default", help="the default preset's folder (general mode)")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--lanes", type=int, default=1 << 20)
    args = ap.parse_args()
    nickel, plastic = str(Path(args.materials) / "nickel"), str(Path(args.materials) / "red_plastic")
    # The same nickel in general mode: the preset's general tables at the material's parameters, as floats.
    material = json.loads((Path(nickel) / "epd_g1.manifest.json").read_text())["material"]
    general = {"tables": args.tables, **{k: material[k] for k in ("beta", "p", "sigma_s", "b", "c")}}
    red = [(400, 0.04), (500, 0.04), (550, 0.06), (600, 0.45), (650, 0.75), (700, 0.8)]  # red_plastic's diffuse, nm
    bsdfs = {
        "roughconductor": {"type": "roughconductor", "distribution": "beckmann", "alpha": 0.03, **render.conductor("Ni_palik")},
        "twoscale exact": {"type": "twoscale", "tables": nickel, "lobe": "exact", **render.conductor("Ni_palik")},
        "twoscale fit": {"type": "twoscale", "tables": nickel, "lobe": "fit", **render.conductor("Ni_palik")},
        "twoscale comp.": {"type": "twoscale", "tables": nickel, "lobe": "exact", "energy": "compensated", **render.conductor("Ni_palik")},
        "general exact": {"type": "twoscale", **general, "lobe": "exact", **render.conductor("Ni_palik")},
        "general fit": {"type": "twoscale", **general, "lobe": "fit", **render.conductor("Ni_palik")},
        "roughplastic": {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.08, "int_ior": 1.5, "nonlinear": True,
                         "diffuse_reflectance": {"type": "spectrum", "value": red}},
        "twoscale plastic": {"type": "twoscale", "tables": plastic},
    }
    film = render.rgb_film(args.res)
    scenes = {name: mi.load_dict(render.scene(b, film, args.spp)) for name, b in bsdfs.items()}
    first, times = {}, {name: [] for name in scenes}
    for name, s in scenes.items():
        t0 = time.time()
        mi.render(s, seed=0)
        first[name] = time.time() - t0
    for k in range(args.repeat):
        for name, s in scenes.items():
            t0 = time.time()
            mi.render(s, seed=k + 1)
            times[name].append(time.time() - t0)
    samples = args.res * args.res * args.spp
    base = statistics.median(times["roughconductor"])
    print(f"{args.res} x {args.res}, {args.spp} spp, median of {args.repeat} renders "
          f"({mi.variant()}, symbolic mode; 'first' = kernel compilation + render):")
    print(f"{'BSDF':<18} {'first s':>8} {'median s':>9} {'Msamples/s':>11} {'throughput / roughconductor':>28}")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:<18} {first[name]:8.2f} {med:9.3f} {samples / med / 1e6:11.2f} {base / med:28.2f}")


    print(f"\nBSDF calls alone: sample() + eval_pdf() over {args.lanes} lanes, median of {args.repeat}:")
    print(f"{'BSDF':<18} {'ns per lane':>12} {'cost / roughconductor':>22}")
    rng = np.random.default_rng(1)
    cos_t = rng.uniform(0.05, 1.0, args.lanes)
    phi = rng.uniform(0, 2 * np.pi, args.lanes)
    sin_t = np.sqrt(1 - cos_t**2)
    wi = [mi.Float(x.astype(np.float32)) for x in (sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t)]
    xi = [mi.Float(rng.random(args.lanes).astype(np.float32)) for _ in range(3)]
    lam = mi.Float(rng.uniform(360, 830, args.lanes).astype(np.float32))
    cost = {}
    for name, d in bsdfs.items():
        bsdf = mi.load_dict(d)
        si = dr.zeros(mi.SurfaceInteraction3f, args.lanes)
        si.wi = mi.Vector3f(*wi)
        si.wavelengths = mi.Spectrum(lam, lam * 0.9 + 40, lam * 0.8 + 80, lam * 0.7 + 120)
        ctx = mi.BSDFContext()
        ts = []
        for _ in range(args.repeat + 1):  # the first compiles the kernel
            t0 = time.time()
            bs, w = bsdf.sample(ctx, si, xi[0], mi.Point2f(xi[1], xi[2]))
            v, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
            dr.eval(bs.wo, w, v, pdf)
            dr.sync_thread()
            ts.append(time.time() - t0)
        cost[name] = statistics.median(ts[1:]) / args.lanes * 1e9
        print(f"{name:<18} {cost[name]:12.1f} {cost[name] / cost['roughconductor']:22.2f}")
    print(f"\ngeneral mode against the per-material BSDF (the same nickel): render throughput "
          f"{statistics.median(times['twoscale exact']) / statistics.median(times['general exact']):.2f} (exact), "
          f"{statistics.median(times['twoscale fit']) / statistics.median(times['general fit']):.2f} (fit); BSDF calls cost "
          f"{cost['general exact'] / cost['twoscale exact']:.2f} (exact), {cost['general fit'] / cost['twoscale fit']:.2f} (fit)")
    print(f"the plastic against roughplastic: render throughput "
          f"{statistics.median(times['roughplastic']) / statistics.median(times['twoscale plastic']):.2f}, "
          f"BSDF calls cost {cost['twoscale plastic'] / cost['roughplastic']:.2f}")


if __name__ == "__main__":
    main()
