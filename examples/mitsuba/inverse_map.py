"""Inverse rendering of a spatially varying map with the `twoscale` BSDF's general mode: recover an 8 x 8 beta map
(a bitmap texture, one value per texel) from renders of a known map, by gradient descent (mi.ad.Adam, gradients by
dr.backward through the BSDF and the bitmap's texels).

A flat square of the general-mode material (tables-out/default; p, sigma_s, b and c fixed floats, F = 1) seen from
straight above by an orthographic camera, lit by an environment that is a bright cap of CAP degrees about the zenith
over a dim sky: every point reflects the cap, so each pixel's value is the share of its lobe that the cap holds, which
falls as beta grows. `prb` (max depth 2) in llvm_ad_spectral; the target and every iterate render with the same
primal seed, so that their difference is the map's and not the noise's. It optimises ln beta per texel, clamped to
the tables' domain, against the images' relative squared difference (a pixel's value goes as 1 / beta^2: a plain
squared difference would leave the rough texels, 200 times dimmer than the polished ones, to the end).

    python -m examples.mitsuba.inverse_map [--tables tables-out/default] [--iterations 200] [--res 64] [--spp 16] [--lr 0.05]

Prints the target map's range, the relative error of the recovered map (median and max over the 64 texels) every 10
iterations, the time, and the iteration at which every texel came within 2 % of its target.
"""
import argparse
import math
import time

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_spectral")

import twoscale_mitsuba  # noqa: E402,F401  (registers the plugin)

N = 8  # texels per side
CAP = 2.0  # degrees: the bright cap's half-angle, narrower than every lobe (4 beta rad), so a pixel goes as 1 / beta^2
BETA_DOMAIN = (0.005, 0.5)


def target_map():
    """A known 8 x 8 map over beta 0.02-0.3: a diagonal ramp, a polished (low beta) square and a rough stripe."""
    y, x = np.mgrid[0:N, 0:N]
    beta = 0.04 * np.exp(np.log(6.0) * (x + y) / (2 * (N - 1)))  # 0.04 .. 0.24 along the diagonal
    beta[1:3, 5:7] = 0.02
    beta[6, :] = 0.3
    return beta.astype(np.float32)


def sky(w=1024):
    """A lat-long environment: radiance 1 within CAP degrees of the zenith (+z), 1e-3 elsewhere (a brighter sky would
    outshine the cap in the rough texels, whose share of it is smallest)."""
    h = w // 2
    theta = (np.arange(h) + 0.5) / h * math.pi
    img = np.where(theta < math.radians(CAP), 1.0, 1e-3)[:, None, None] * np.ones((1, w, 3))
    return mi.Bitmap(img.astype(np.float32))


def scene(tables, beta, res, spp):
    material = {"type": "twoscale", "tables": tables, "fresnel": "one", "p": 1.2, "sigma_s": 0.02, "b": 1.5, "c": 2.2,
                "beta": {"type": "bitmap", "bitmap": mi.Bitmap(beta[..., None]), "raw": True, "filter_type": "nearest"}}
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "prb", "max_depth": 2},
        "sensor": {"type": "orthographic",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 2], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "square": {"type": "rectangle", "bsdf": material},
        # The envmap's up is its +y; turned so that the bright cap sits about the square's normal (+z).
        "sky": {"type": "envmap", "bitmap": sky(), "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], 90)},
    })


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tables", default="tables-out/default", help="the default preset's folder")
    ap.add_argument("--iterations", type=int, default=200)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--lr", type=float, default=0.05)
    args = ap.parse_args()
    target = target_map()
    sc = scene(args.tables, target, args.res, args.spp)
    params = mi.traverse(sc)
    key = "square.bsdf.beta.data"
    target_img = mi.render(sc, seed=0)

    start = np.full_like(target, 0.1)
    opt = mi.ad.Adam(lr=args.lr, beta_2=0.99)  # a shorter memory of the early, large gradients: the rough texels keep their pace
    opt["ln_beta"] = mi.TensorXf(np.log(start)[..., None])

    def apply():
        params[key] = dr.clip(dr.exp(opt["ln_beta"]), *BETA_DOMAIN)
        params.update()

    def error():
        now = np.asarray(params[key])[..., 0]
        return np.abs(now / target - 1.0)

    print(f"target: an {N} x {N} beta map over {target.min():.3f}-{target.max():.3f}; start: beta 0.1 everywhere; "
          f"{args.res} x {args.res}, {args.spp} spp, prb, Adam (learning rate {args.lr}) on ln beta")
    apply()
    converged, t0 = None, time.time()
    for it in range(args.iterations):
        img = mi.render(sc, params, seed=0, seed_grad=it + 1)
        loss = dr.mean(dr.square((img - target_img) / (target_img + 1e-3)), axis=None)
        dr.backward(loss)
        opt.step()
        apply()
        err = error()
        if converged is None and err.max() <= 0.02:
            converged = it + 1
        if it % 10 == 0 or it == args.iterations - 1:
            print(f"iteration {it:3d}: loss {float(np.ravel(loss)[0]):.3e}  map error median {np.median(err):.1e}, "
                  f"max {err.max():.1e}", flush=True)
    err = error()
    row, col = (int(i) for i in np.unravel_index(err.argmax(), err.shape))
    print(f"{args.iterations} iterations in {time.time() - t0:.1f} s: recovered map's relative error median "
          f"{np.median(err):.1e}, max {err.max():.1e} (texel row {row}, column {col}, target {target[row, col]:g}); every texel "
          + (f"within 2 % from iteration {converged}" if converged else "not yet within 2 %"))


if __name__ == "__main__":
    main()
