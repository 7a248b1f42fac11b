"""Inverse rendering with the `twoscale` BSDF: recover sigma_s and the conductor index (eta, k) of a
target render by gradient descent (mi.ad.Adam, gradients by dr.backward through the BSDF).

A sphere under four point lights whose highlights (with their diffraction halos) lie at
theta_d = 5, 30, 55 and 80 deg, so that the image holds the Fresnel factor from normal to grazing
incidence; `prb` (max depth 2: direct light from point lights, so the image and its gradient are
almost free of noise) in llvm_ad_spectral.
The target is rendered with the material folder's sigma_s and a given (eta, k) (uniform spectra);
the optimisation starts from other values and minimises the mean squared difference of the images.
It optimises ln sigma_s, ln eta and ln k, so that the three stay positive and share one learning rate.
b stays the folder's (its gradient flows through the tables' coordinates too; see the README).

    python -m examples.mitsuba.inverse --material DIR/scene-render_materials/b2 [--iterations 200] [--res 64] [--spp 32]

Prints the start, target and result, the loss every 10 iterations, the time, and how far the
recovered Fresnel factor F(theta) is from the target's: a constant index's F(theta) is nearly a
one-parameter family (F at normal incidence and the "edge tint", Gulbrandsen 2014), so (eta, k)
move slowly along a shallow valley once F(theta) matches.
"""
import argparse
import json
import math
import time
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_spectral")

from examples.mitsuba import render  # noqa: E402  (this folder's scene)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--material", required=True, help="a material folder with diffraction (sigma_s > 0)")
    ap.add_argument("--target", type=float, nargs=2, default=(0.4, 2.5), metavar=("ETA", "K"))
    ap.add_argument("--start", type=float, nargs=3, default=None, metavar=("SIGMA_S", "ETA", "K"),
                    help="default: sigma_s halved, eta 1.2, k 1.5")
    ap.add_argument("--iterations", type=int, default=200)
    ap.add_argument("--lr", type=float, default=0.05)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--spp", type=int, default=32)
    args = ap.parse_args()
    sigma_s = json.loads((Path(args.material) / "epd_g1.manifest.json").read_text())["material"]["sigma_s"]
    target = {"sigma_s": sigma_s, "eta": args.target[0], "k": args.target[1]}
    start = dict(zip(("sigma_s", "eta", "k"), args.start or (sigma_s / 2, 1.2, 1.5)))

    bsdf = {"type": "twoscale", "tables": args.material, "eta": target["eta"], "k": target["k"]}
    scene = {
        "type": "scene",
        "integrator": {"type": "prb", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 35,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": render.rgb_film(args.res), "sampler": {"type": "independent", "sample_count": args.spp}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
    }
    # Point lights at 10, 60, 110 and 160 deg from the view direction: highlights at theta_d = 5, 30,
    # 55 and 80 deg sample the Fresnel factor from normal to grazing incidence.
    for j, alpha in enumerate((10, 60, 110, 160)):
        a = math.radians(alpha)
        scene[f"light{j}"] = {"type": "point", "position": [6 * math.sin(a), 0.6 * (j - 1.5), 6 * math.cos(a)], "intensity": 40.0}
    scene = mi.load_dict(scene)
    params = mi.traverse(scene)
    keys = {"sigma_s": "sphere.bsdf.sigma_s", "eta": "sphere.bsdf.eta.value", "k": "sphere.bsdf.k.value"}
    # The target and every iterate use the same primal samples (seed 0), so that their difference is
    # the parameters' and not the noise's; the adjoint pass draws its own (seed_grad).
    target_img = mi.render(scene, seed=0)

    opt = mi.ad.Adam(lr=args.lr)
    for name, value in start.items():
        opt[name] = mi.Float(math.log(value))

    def apply():
        for name, key in keys.items():
            params[key] = dr.exp(opt[name])
        params.update()

    t0 = time.time()
    apply()
    for it in range(args.iterations):
        img = mi.render(scene, params, seed=0, seed_grad=it + 1)
        loss = dr.mean(dr.square(img - target_img), axis=None)
        dr.backward(loss)
        opt.step()
        apply()
        if it % 10 == 0 or it == args.iterations - 1:
            now = {name: math.exp(float(np.ravel(opt[name])[0])) for name in keys}
            print(f"iteration {it:3d}: loss {float(np.ravel(loss)[0]):.3e}  "
                  + "  ".join(f"{n} {v:.4f}" for n, v in now.items()), flush=True)
    secs = time.time() - t0
    result = {name: math.exp(float(np.ravel(opt[name])[0])) for name in keys}
    print(f"{args.iterations} iterations of {args.res} x {args.res}, {args.spp} spp in {secs:.1f} s")
    for name in keys:
        print(f"{name:8s} start {start[name]:.4f}  target {target[name]:.4f}  result {result[name]:.4f} "
              f"({result[name] / target[name] - 1:+.1%})")
    theta = np.linspace(0.0, 89.0, 90)
    cos_t = mi.Float(np.cos(np.radians(theta)))
    fresnel = {which: np.asarray(mi.fresnel_conductor(cos_t, dr.llvm.ad.Complex2f(v["eta"], v["k"])), dtype=np.float64)
               for which, v in (("start", start), ("target", target), ("result", result))}
    for which in ("start", "result"):
        print(f"F(theta) of the {which} against the target's over theta in [0, 89] deg: max |difference| "
              f"{np.abs(fresnel[which] - fresnel['target']).max():.4f}")


if __name__ == "__main__":
    main()
