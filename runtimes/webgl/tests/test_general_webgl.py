"""twoscale.js' loadTables and evalPoints on the general export (twoscale_general.js, ts_general_eval in
twoscale_brdf.glsl), in headless Chromium (SwiftShader's WebGL2), against the numpy model on the same tables
uncompressed (runtimes/testing/twoscale_model.py). One page load; `pytest -rP runtimes/webgl -k general_webgl`
prints the figures:

  eval     1,000 random points, each with its own parameters over the default domain (half with diffraction),
           both lobes, F = 1 and a conductor: relative difference where rho >= 1e-3 1/sr within 1e-3 (the issue's
           bar for exact float32 values, met with zh_lobe's float16 residual too), absolute below;
  agree    against the per-material export of the same material (loadMaterial) at 6 test materials, 2,000 random
           (wi, wo, lambda) each, both lobes, direct and baked: median <= 0.5 %, p99 <= 3 % where rho >= 1e-3 of
           its largest;
  baked    the explorer sphere's bake (evalPoints with baked): 8 sets of one (p, sigma_s, b, c), beta over a map's
           range, against the numpy model: median <= 1e-3, p99 <= 1e-2 where rho >= 1e-3 of the set's largest;
  mitsuba  ts_general_sample, ts_general_pdf and evalPoints (energy compensated too) against the Mitsuba BSDF's
           general mode at the same 6 materials' parameters, both lobes and energies, 200 inputs each: the same wo,
           pdf and weight;
  reject   loadTables refuses a corrupted and a missing binary, a changed descriptor and a missing SHA256SUMS,
           naming the file; evalPoints refuses a parameter outside the domain, naming it.
"""
import base64
import json
import shutil

import numpy as np
import pytest
from browser import Server, export_webgl, run_page
from checks import params_of, random_pair, random_pairs, report
from twoscale_c import REPO
from twoscale_model import TwoScaleModel, open_tables

N = 1000
# As the Mitsuba BSDF's general-mode test: without diffraction (chi2, chi4) and with it, beta 0.03-0.4, p 0.3-4.
AGREE = ["chi2", "chi4", "chi6", "chi7", "chi9", "chi12"]
N_AGREE = 2000
N_SAMPLE = 200
# The sphere's bake: sets of one (p, sigma_s, b, c), beta over a map's range.
N_BAKED_SETS, N_BAKED = 8, 250
MODES = [(lobe, energy) for lobe in ("exact", "fit") for energy in ("single", "compensated")]
# Each point has its own parameters, so no one largest rho scales them all: relative differences where rho >= 1e-3
# 1/sr, absolute ones below.
FLOOR = 1e-3
FRESNEL = {"eta": 0.2, "k": 3.1}


def conductor(eta, k, c):
    """The unpolarised Fresnel reflectance of eta + i k at cos c (docs/runtimes.md), in double."""
    c2, s2 = c * c, 1.0 - c * c
    t1 = eta * eta - k * k - s2
    ab = np.sqrt(t1 * t1 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (ab + t1), 0.0))
    rs = (ab + c2 - 2.0 * c * a) / (ab + c2 + 2.0 * c * a)
    t3 = ab * c2 + s2 * s2
    return rs * t3 / (t3 + 2.0 * c * a * s2)


def random_points(rng, n):
    """[n, 14] float32: wi, wo, lambda, beta, p, sigma_s, b, c, eta, k; parameters over the default domain."""
    x = np.zeros((n, 14))
    for i in range(n):
        diffracts = i % 2 == 0
        beta = float(np.exp(rng.uniform(np.log(0.005), np.log(0.5))))
        p = rng.uniform(0.2, 5.0) if diffracts else float(np.exp(rng.uniform(np.log(0.05), np.log(5.0))))
        sigma_s = float(np.exp(rng.uniform(np.log(0.005), np.log(0.2)))) if diffracts else 0.0
        b = float(np.exp(rng.uniform(np.log(0.083), np.log(36.0))))
        wi, wo = random_pair(rng, beta if i % 4 < 2 else 1.0)
        x[i] = [*wi, *wo, rng.uniform(0.36, 0.83), beta, p, sigma_s, b, rng.uniform(1.02, 3.02), FRESNEL["eta"], FRESNEL["k"]]
    return x.astype(np.float32)


def reference(tables, x, lobe):
    """(specular, diffraction) parts of rho / F of the numpy model at each point (its own parameters), in double
    from the float32 inputs."""
    x = x.astype(np.float64)
    out = np.zeros((2, len(x)))
    for i, q in enumerate(x):
        m = TwoScaleModel(tables, q[7], q[8], q[9], q[10], q[11], lobe=lobe)
        spec, diff = m.eval_parts(q[None, 0:3], q[None, 3:6], q[6])
        out[:, i] = spec[0], diff[0]
    return out


def agree_points(rng, m):
    """[n, 14] float32 points of material m (wi, wo, lambda in its range, its parameters; eta, k unused)."""
    wi, wo = random_pairs(rng, m["beta"], 3 * N_AGREE // 4, N_AGREE // 4)
    lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.36, 0.83)
    x = np.zeros((N_AGREE, 14))
    x[:, 0:3], x[:, 3:6], x[:, 6] = wi, wo, rng.uniform(lo, hi, N_AGREE)
    x[:, 7:12] = [m["beta"], m["p"], m.get("sigma_s") or 0.0, m.get("b") or 1.0, m.get("c") or 2.0]
    return x.astype(np.float32)


def baked_points(rng):
    """[N_BAKED_SETS * N_BAKED, 14] float32: sets of points as the explorer's sphere with a beta map draws them, each set
    one (p, sigma_s, b, c) and beta = beta0 4^(2v - 1) within the domain, v uniform."""
    x = np.zeros((N_BAKED_SETS * N_BAKED, 14))
    for k in range(N_BAKED_SETS):
        beta0 = float(np.exp(rng.uniform(np.log(0.01), np.log(0.3))))
        p, sigma_s = rng.uniform(0.3, 5.0), float(np.exp(rng.uniform(np.log(0.005), np.log(0.2))))
        b, c = float(np.exp(rng.uniform(np.log(0.083), np.log(36.0)))), rng.uniform(1.02, 3.02)
        for i in range(k * N_BAKED, (k + 1) * N_BAKED):
            beta = float(np.clip(beta0 * 4.0 ** rng.uniform(-1.0, 1.0), 0.00501, 0.499))  # float32 stays inside
            wi, wo = random_pair(rng, beta if i % 2 else 1.0)
            x[i] = [*wi, *wo, rng.uniform(0.36, 0.83), beta, p, sigma_s, b, c, FRESNEL["eta"], FRESNEL["k"]]
    return x.astype(np.float32)


@pytest.fixture(scope="module")
def general_run(tables, materials, tmp_path_factory):
    from test_general_export import export

    data = tmp_path_factory.mktemp("general-webgl")
    out = export(tables, data / "general")
    rng = np.random.default_rng(61)
    x = random_points(rng, N)
    (data / "points.bin").write_bytes(x.tobytes())
    case = {"general": [], "generalRejects": [], "materials": {}, "evals": []}
    agree = {}
    for name in AGREE:
        m = params_of(materials / name)
        export_webgl(materials / name, data / name)
        xa = agree_points(rng, m)
        agree[name] = xa
        (data / f"{name}.bin").write_bytes(xa.tobytes())
        # the material export's harness layout: wi, wo, lambda, eta, k
        (data / f"{name}-material.bin").write_bytes(np.concatenate([xa[:, 0:7], xa[:, 12:14]], axis=1).tobytes())
        case["materials"][name] = f"/data/{name}/material.json"
        for lobe in ("exact", "fit"):
            for baked in (False, True):
                case["general"].append({"id": f"agree-{name}-{lobe}{'-baked' * baked}", "tables": "/data/general/tables.json",
                                        "points": f"/data/{name}.bin", "opts": {"lobe": lobe, "baked": baked}})
            case["evals"].append({"id": f"material-{name}-{lobe}", "material": name, "points": f"/data/{name}-material.bin",
                                  "opts": {"lobe": lobe}})
    for lobe in ("exact", "fit"):
        for fr in ("one", "conductor"):
            case["general"].append({"id": f"{lobe}-{fr}", "tables": "/data/general/tables.json", "points": "/data/points.bin",
                                    "opts": {"lobe": lobe, "fresnel": fr}})
    xb = baked_points(rng)
    (data / "baked.bin").write_bytes(xb.tobytes())
    for lobe in ("exact", "fit"):
        for k in range(N_BAKED_SETS):
            case["general"].append({"id": f"baked-{lobe}-{k}", "tables": "/data/general/tables.json", "points": "/data/baked.bin",
                                    "range": [k * N_BAKED, (k + 1) * N_BAKED], "opts": {"lobe": lobe, "baked": True}})
    samples = {}
    for name in AGREE:
        m = params_of(materials / name)
        lo, hi = (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.36, 0.83)
        xs = np.zeros((N_SAMPLE, 16))
        for i in range(N_SAMPLE):
            wi, wo = random_pair(rng, m["beta"] if i % 2 else 1.0)
            xs[i, 0:3], xs[i, 13:16] = wi, wo
        xs[:, 3], xs[:, 4:6] = rng.uniform(lo, hi, N_SAMPLE), rng.uniform(0.0, 1.0, (N_SAMPLE, 2))
        xs[:, 6:11] = [m["beta"], m["p"], m.get("sigma_s") or 0.0, m.get("b") or 1.0, m.get("c") or 2.0]
        xs = xs.astype(np.float32)
        samples[name] = xs
        (data / f"{name}-samples.bin").write_bytes(xs.tobytes())
        # the eval points of the same inputs: wi, wo given, lambda0, parameters
        xe = np.concatenate([xs[:, 0:3], xs[:, 13:16], xs[:, 3:4], xs[:, 6:11], np.zeros((N_SAMPLE, 2), np.float32)], axis=1)
        (data / f"{name}-eval.bin").write_bytes(xe.tobytes())
        for lobe, energy in MODES:
            case.setdefault("generalSamples", []).append({"id": f"sample-{name}-{lobe}-{energy}", "tables": "/data/general/tables.json",
                                                          "lobe": lobe, "energy": energy, "inputs": f"/data/{name}-samples.bin"})
            case["general"].append({"id": f"eval-{name}-{lobe}-{energy}", "tables": "/data/general/tables.json",
                                    "points": f"/data/{name}-eval.bin", "opts": {"lobe": lobe, "energy": energy}})
    out_of_domain = x[:1].copy()
    out_of_domain[0, 7] = 0.9  # beta above the domain
    (data / "bad-point.bin").write_bytes(out_of_domain.tobytes())
    case["general"].append({"id": "outside", "tables": "/data/general/tables.json", "points": "/data/bad-point.bin", "opts": {}})
    expect = {}
    for what in ("corrupted", "missing", "descriptor", "sums"):
        bad = shutil.copytree(out, data / f"bad-{what}")
        desc = json.loads((bad / "tables.json").read_text())
        if what == "corrupted":
            b = bytearray((bad / "zh_lobe.bin").read_bytes())
            b[123457] ^= 0x10
            (bad / "zh_lobe.bin").write_bytes(b)
            expect[what] = "zh_lobe.bin: SHA-256 mismatch (expected "
        elif what == "missing":
            (bad / "kcorr_renorm.bin").unlink()
            expect[what] = "kcorr_renorm.bin: HTTP 404"
        elif what == "descriptor":
            text = (bad / "tables.json").read_text()
            (bad / "tables.json").write_text(text.replace('"theta_cap": 1.45', '"theta_cap": 1.46', 1))
            assert (bad / "tables.json").read_text() != text
            expect[what] = "tables.json: SHA-256 mismatch (SHA256SUMS has "
        else:
            (bad / "SHA256SUMS").unlink()
            expect[what] = "SHA256SUMS: HTTP 404"
        del desc
        case["generalRejects"].append({"id": f"reject-{what}", "url": f"/data/bad-{what}/tables.json"})
    (data / "case.json").write_text(json.dumps(case))
    with Server({"/runtime/": REPO / "runtimes/webgl", "/data/": data}) as srv:
        page = run_page(srv.url("/runtime/tests/harness.html?case=/data/case.json"), budget_ms=120000, timeout=600)
    status = page.text("status")
    assert status == "done", f"harness page: {status!r}; console: {page.console[-20:]}"
    return json.loads(page.text("result")), x, expect, samples, xb, open_tables(tables, ["epd_g1", "epd_norm", "kcorr_renorm", "zh_convolution", "zh_lobe"])


def decode(r):
    assert "error" not in r, r
    return np.frombuffer(base64.b64decode(r), dtype=np.float32).astype(np.float64)


def test_general_webgl_eval_against_numpy(general_run):
    results, x, _, _, _, t = general_run
    lines, worst = [], {}
    xd = x.astype(np.float64)
    cos_d = np.sqrt(np.clip(0.5 + 0.5 * np.sum(xd[:, 0:3] * xd[:, 3:6], axis=1), 0.0, 1.0))
    for lobe in ("exact", "fit"):
        spec, diff = reference(t, x, lobe)
        want0 = spec + diff
        for fr in ("one", "conductor"):
            gpu = decode(results[f"{lobe}-{fr}"])
            want = want0 if fr == "one" else want0 * conductor(FRESNEL["eta"], FRESNEL["k"], cos_d)
            keep = want >= FLOOR
            rel = np.abs(gpu[keep] - want[keep]) / want[keep]
            below = np.abs(gpu[~keep] - want[~keep]).max(initial=0.0)
            worst[(lobe, fr)] = (np.median(rel), np.percentile(rel, 99), rel.max(), below)
            lobe_led = (diff[keep] >= 0.5 * want0[keep])
            lines.append(f"  {lobe:5s} {fr:9s} {keep.sum()} points: median {np.median(rel):.2e}, p99 {np.percentile(rel, 99):.2e}, "
                         f"max {rel.max():.2e} (the {lobe_led.sum()} where diffraction is most of rho: max {rel[lobe_led].max(initial=0):.2e}); "
                         f"below {FLOOR:g} 1/sr, max |diff| {below:.2e} 1/sr")
    ok = all(m <= 1e-5 and p <= 1e-3 and mx <= 1e-3 and b <= 1e-6 for m, p, mx, b in worst.values())
    report(ok, f"eval: evalPoints on the general export against the numpy model (the tables uncompressed), {N} points, "
               f"each its own parameters (bar: median 1e-5, max 1e-3 where rho >= {FLOOR:g} 1/sr, 1e-6 1/sr below):\n" + "\n".join(lines))


def test_general_webgl_agrees_with_material_exports(general_run):
    results = general_run[0]
    lines, ok = [], True
    for lobe in ("exact", "fit"):
        for baked in ("", "-baked"):
            for name in AGREE:
                gen, mat = decode(results[f"agree-{name}-{lobe}{baked}"]), decode(results[f"material-{name}-{lobe}"])
                keep = mat >= 1e-3 * mat.max()
                rel = np.abs(gen[keep] - mat[keep]) / mat[keep]
                med, p99 = np.median(rel), np.percentile(rel, 99)
                ok &= med <= 5e-3 and p99 <= 3e-2
                lines.append(f"  {lobe:5s} {baked[1:] or 'direct':6s} {name:6s} {keep.sum()} points: median {med:.2e}, p99 {p99:.2e}, max {rel.max():.2e}")
    report(ok, f"agree: evalPoints on the general export (direct, and baked as the sphere reads it) against the material's own "
               f"export, {N_AGREE} points each (bar: median 5e-3, p99 3e-2 where rho >= 1e-3 of its largest):\n" + "\n".join(lines))


def test_general_webgl_baked_against_numpy(general_run):
    """The bake the explorer's sphere reads with a beta map: evalPoints baked over each set's beta range against the
    numpy model (the tables uncompressed). Bar: what runtimes/webgl/README.md "The bake" states, median 1e-3 and
    p99 1e-2 where rho >= 1e-3 of the set's largest."""
    results, _, _, _, xb, t = general_run
    lines, ok = [], True
    for lobe in ("exact", "fit"):
        rels = []
        for k in range(N_BAKED_SETS):
            x = xb[k * N_BAKED:(k + 1) * N_BAKED]
            spec, diff = reference(t, x, lobe)
            want, gpu = spec + diff, decode(results[f"baked-{lobe}-{k}"])
            keep = want >= 1e-3 * want.max()
            rels.append(np.abs(gpu[keep] - want[keep]) / want[keep])
        rel = np.concatenate(rels)
        med, p99 = np.median(rel), np.percentile(rel, 99)
        ok &= med <= 1e-3 and p99 <= 1e-2
        lines.append(f"  {lobe:5s} {rel.size} points: median {med:.2e}, p99 {p99:.2e}, max {rel.max():.2e}")
    report(ok, f"baked: evalPoints baked over a beta map's range against the numpy model, {N_BAKED_SETS} sets of (p, sigma_s, b, c) "
               f"x {N_BAKED} points, beta = beta0 4^(2v - 1) (bar: median 1e-3, p99 1e-2 where rho >= 1e-3 of the set's largest):\n"
               + "\n".join(lines))


def test_general_webgl_rejects(general_run):
    results, _, expect = general_run[:3]
    lines, ok = [], True
    for what, prefix in expect.items():
        got = results[f"reject-{what}"]["rejected"]
        ok &= bool(got) and got.startswith(prefix)
        lines.append(f"  {what}: {got}")
    msg = results["outside"].get("error", "") if isinstance(results["outside"], dict) else ""
    ok &= "beta = " in msg and "outside the domain [0.005, 0.5]" in msg
    lines.append(f"  a point's beta outside the domain: {msg}")
    report(ok, "reject: loadTables and evalPoints refuse, naming the file or the parameter:\n" + "\n".join(lines))


def test_general_webgl_sample_pdf_eval_against_mitsuba(general_run, variant_llvm_ad_spectral, tables):
    import drjit as dr
    import mitsuba as mi
    import twoscale_mitsuba  # noqa: F401  (registers the plugin)

    results, samples = general_run[0], general_run[3]
    def vec(a):
        return mi.Vector3f(*[mi.Float(a[:, j]) for j in range(3)])

    lines, ok = [], True
    for name, xs in samples.items():
        wi, lam, xi, wo_given = xs[:, 0:3], xs[:, 3], xs[:, 4:6], xs[:, 13:16]
        beta, p, sigma_s, b, c = (float(v) for v in xs[0, 6:11])
        for lobe, energy in MODES:
            bsdf = mi.load_dict({"type": "twoscale", "tables": str(tables), "fresnel": "one", "lobe": lobe, "energy": energy,
                                 "beta": beta, "p": p, "sigma_s": sigma_s, "b": b, "c": c})
            si = dr.zeros(mi.SurfaceInteraction3f, len(xs))
            si.wi = vec(wi)
            si.wavelengths = mi.Spectrum(mi.Float(1e3 * lam))
            ctx = mi.BSDFContext()
            bs, w = bsdf.sample(ctx, si, mi.Float(0.0), mi.Point2f(mi.Float(xi[:, 0]), mi.Float(xi[:, 1])))
            wo_m = np.stack([np.asarray(bs.wo[j], np.float64) for j in range(3)], axis=1)
            pdf_m, w_m = np.asarray(bs.pdf, np.float64), np.asarray(w[0], np.float64)
            pdf_given_m = np.asarray(bsdf.pdf(ctx, si, vec(wo_given)), np.float64)
            up = wo_given[:, 2] > 0
            eval_m = np.where(up, np.asarray(bsdf.eval(ctx, si, vec(wo_given))[0], np.float64) / np.where(up, wo_given[:, 2], 1.0), 0.0)
            out = decode(results[f"sample-{name}-{lobe}-{energy}"]).reshape(-1, 8)
            wo_g, pdf_g, w_g, pdf_at_g, pdf_given_g = out[:, 0:3], out[:, 3], out[:, 4], out[:, 5], out[:, 6]
            eval_g = decode(results[f"eval-{name}-{lobe}-{energy}"])
            kept = (pdf_m > 0) & (pdf_g > 0)
            lost = int(((pdf_m > 0) != (pdf_g > 0)).sum())
            d_wo = float(np.abs(wo_g - wo_m)[kept].max(initial=0.0))
            sig = kept & (pdf_m >= 1e-4 * pdf_m.max())
            r_pdf = float((np.abs(pdf_g - pdf_m) / np.where(sig, pdf_m, 1.0))[sig].max(initial=0.0))
            r_w = float((np.abs(w_g - w_m) / np.maximum(np.abs(w_m), 1e-30))[sig & (w_m > 0)].max(initial=0.0))
            r_self = float((np.abs(pdf_at_g - pdf_g) / np.where(kept, pdf_g, 1.0))[kept].max(initial=0.0))
            sig_g = pdf_given_m >= 1e-4 * pdf_given_m.max()
            r_given = float((np.abs(pdf_given_g - pdf_given_m)[sig_g] / pdf_given_m[sig_g]).max(initial=0.0))
            sig_e = eval_m >= 1e-3 * eval_m.max()
            r_eval = float((np.abs(eval_g - eval_m)[sig_e] / eval_m[sig_e]).max(initial=0.0))
            good = lost == 0 and d_wo <= 1e-4 and r_pdf <= 2e-3 and r_w <= 2e-3 and r_self <= 1e-5 and r_given <= 2e-3 and r_eval <= 1e-3
            ok &= good
            lines.append(f"  {name:6s} {lobe:5s} {energy:11s} {int(kept.sum())} kept, {lost} lost by one only; |wo - wo_m| {d_wo:.1e}; rel: "
                         f"pdf {r_pdf:.1e}, weight {r_w:.1e}, own pdf at wo {r_self:.1e}, pdf at given wo {r_given:.1e}, eval {r_eval:.1e}"
                         + ("" if good else "  <- FAILED"))
    report(ok, f"mitsuba: ts_general_sample / ts_general_pdf / evalPoints against the Mitsuba BSDF's general mode, {N_SAMPLE} inputs "
               "each (none lost by one only, wo within 1e-4, pdf and weight within 2e-3, eval within 1e-3 where not tiny):\n" + "\n".join(lines))
