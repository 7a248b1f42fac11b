"""The GPU runtime (twoscale_brdf.glsl through twoscale.js) against the C reference BRDF, in headless Chromium
(SwiftShader's WebGL2: a CPU rasteriser, float32 as on a GPU). One page load (tests/harness.html) runs every
case; `pytest -rP runtimes/webgl -k brdf` prints the measured figures:

  eval     ts_eval by evalPoints at 1,000 random (wi, wo, lambda) per material (half about the mirror direction,
           half anywhere; lambda uniform in the material's range), every lobe x energy mode, F = 1; the conductors
           also with a constant {eta, k} and each point's own: |gpu - c| <= 1e-3 c where c >= 1e-4 of the
           material-mode's largest c (the issue's criterion), and <= 1e-3 of that threshold below it;
  sample   ts_sample and ts_pdf (a custom shader over shaderSource / fragmentShader / bindMaterial) against
           twoscale_brdf_sample / _pdf with the same (wi, lambda0, xi): the same wo within 1e-4, pdf and weight
           within 1e-3 where the pdf is not tiny, ts_pdf at given directions within 1e-3;
  bundle   evalPoints on the export of a material folder unpacked from a scene bundle (`twoscale bundle`);
  batch    evalPoints at 65,537 points (two draws) against the C BRDF;
  load     loadMaterial rejects a corrupted, a truncated and a missing binary, a descriptor that is not JSON, one
           whose number changed (SHA256SUMS covers it) and a missing SHA256SUMS, naming the file;
  mitsuba  evalPoints against the Mitsuba BSDF itself at the eval points (chi5, plastic6, subsurface7, 4 modes).

Every eval job's last 12 points are at the domain's edges (edges()).

The GPU sees float32 inputs: the C gets the same values (rounded to float32, then double).
"""
import base64
import json
import math
import shutil
import tarfile
import time

import numpy as np
import pytest
from browser import Server, export_webgl, run_page
from checks import params_of, random_pairs, report
from twoscale_c import REPO, CBrdf

EVAL_MATERIALS = ["chi1", "chi5", "chi7", "furnace6", "plastic6", "plastic7", "subsurface6", "subsurface7"]
FRESNEL_MATERIALS = ["chi1", "chi5", "furnace6"]  # conductors: also a constant {eta, k} and each point's eta, k
SAMPLE_MATERIALS = ["chi5", "plastic6", "subsurface7"]
BUNDLE_MATERIAL = "subsurface6"  # diffracting and layered: every table
MODES = [(lobe, energy) for energy in ("single", "compensated") for lobe in ("exact", "fit")]
N_EVAL, N_SAMPLE = 1000, 400
BATCH = 256 * 256  # twoscale.js' points a draw
MITSUBA_MATERIALS = ["chi5", "plastic6", "subsurface7"]  # evalPoints against the Mitsuba BSDF directly
TOL, FLOOR = 1e-3, 1e-4  # |gpu - c| <= TOL c where c >= FLOOR max c


@pytest.fixture(scope="module")
def webgl_exports(materials, tmp_path_factory):
    """name -> the folder of that test material's GPU export (exported once)."""
    root, done = tmp_path_factory.mktemp("webgl"), {}

    def get(name):
        if name not in done:
            done[name] = export_webgl(materials / name, root / name)
        return done[name]

    return get


def wavelengths(m):
    """A material's wavelength range (micrometres): its tables', else Mitsuba's 0.36-0.83."""
    return (m["wavelength_min"], m["wavelength_max"]) if m.get("sigma_s") else (0.36, 0.83)


def f32(a):
    return np.asarray(a, np.float32).astype(np.float64)


def edges(m):
    """[12, 9] points at the domain's edges: h at the normal (theta_h = 0), wi or wo at or below the horizon,
    grazing, lambda below and above the tables' range (clamped by both runtimes), a dielectric-like k = 0."""
    lo, hi = wavelengths(m)
    s = math.sqrt(0.5)
    rows = [[0, 0, 1, 0, 0, 1, lo], [s, 0, s, -s, 0, s, hi], [0.6, 0, 0.8, -0.6, 0, 0.8, 0.5 * lo],
            [0.6, 0, 0.8, -0.6, 0, 0.8, 2.0 * hi], [1, 0, 0, -0.6, 0, 0.8, lo], [0.6, 0, 0.8, 0.6, 0, -0.8, lo],
            [0.6, 0, 0.8, 1, 0, 0, hi], [0.9999, 0, 0.01414, -0.9999, 0, 0.01414, lo],
            [0, 0.6, 0.8, 0, -0.6, 0.8, 0.5 * (lo + hi)], [0, 0, 1, 0.6, 0, 0.8, 0.1], [0, 0, 1, 0.6, 0, 0.8, 5.0],
            [0.3, 0.4, math.sqrt(0.75), -0.3, -0.4, math.sqrt(0.75), hi]]
    return np.array([r + [1.5, 0.0 if i == 11 else 3.0] for i, r in enumerate(rows)], float)


def points(rng, m, n):
    """float32-exact [n, 9] = wi, wo, lambda, eta, k: n/2 pairs about the mirror direction, n/2 anywhere,
    turned by a random azimuth (the BRDF is isotropic; wi then has x and y); the last 12 at edges()."""
    wi, wo = random_pairs(rng, m["beta"], n // 2, n - n // 2)
    phi = rng.uniform(0, 2 * math.pi, n)
    c, s = np.cos(phi), np.sin(phi)
    turn = lambda v: np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], -1)  # noqa: E731
    lo, hi = wavelengths(m)
    x = np.concatenate([turn(wi), turn(wo), rng.uniform(lo, hi, (n, 1)), rng.uniform(0.2, 2.5, (n, 1)), rng.uniform(0.5, 5.0, (n, 1))], 1)
    x[-12:] = edges(m)
    return f32(x)


def worst(gpu, c):
    """(largest relative error where c >= FLOOR max c, largest |gpu - c| / (FLOOR max c) elsewhere, its point)."""
    floor = FLOOR * c.max()
    big = c >= floor
    rel = np.where(big, np.abs(gpu - c) / np.where(big, c, 1.0), np.abs(gpu - c) / floor)
    rel[~np.isfinite(gpu)] = np.inf
    i = int(np.argmax(np.where(big, rel, 0.0)))
    return float(rel[big].max()), float(rel[~big].max(initial=0.0)), i


def decode(result):
    if isinstance(result, dict):
        raise AssertionError(f"the page failed: {result}")
    return np.frombuffer(base64.b64decode(result), np.float32).astype(np.float64)


@pytest.fixture(scope="module")
def webgl_run(materials, c_cache, webgl_exports, bundle, tmp_path_factory):
    """Builds every case, runs the harness page once, and yields (results, references)."""
    data = tmp_path_factory.mktemp("webgl-case")
    rng = np.random.default_rng(42)
    case = {"materials": {}, "evals": [], "samples": [], "rejects": []}
    ref = {"evals": {}, "samples": {}, "rejects": {}, "points": {}}
    mounts = {"/runtime/": REPO / "runtimes/webgl", "/data/": data}

    def mount(name, folder):
        mounts[f"/m/{name}/"] = folder
        case["materials"][name] = f"/m/{name}/material.json"

    def add_evals(name, folder, modes, fresnels, n=N_EVAL):
        m = params_of(folder)
        x = points(rng, m, n)
        x.astype(np.float32).tofile(data / f"{name}.points.bin")
        ref["points"][name] = x
        wi, wo, lam, eta, k = x[:, 0:3], x[:, 3:6], x[:, 6], x[:, 7], x[:, 8]
        for lobe, energy in modes:
            brdf = CBrdf(folder, lobe, c_cache, energy=energy)
            for fresnel in fresnels:
                jid = f"{name} {lobe} {energy} {fresnel}"
                opts = {"lobe": lobe, "energy": energy, "fresnel": {"one": "one", "eta-k": {"eta": 1.4, "k": 3.2}, "per-point": "conductor"}[fresnel]}
                case["evals"].append({"id": jid, "material": name, "opts": opts, "points": f"/data/{name}.points.bin"})
                if fresnel == "one":
                    ref["evals"][jid] = brdf.eval(wi, wo, lam)
                elif fresnel == "eta-k":
                    ref["evals"][jid] = brdf.eval(wi, wo, lam, eta=f32(1.4), k=f32(3.2))
                else:
                    ref["evals"][jid] = brdf.eval(wi, wo, lam, eta=eta, k=k)

    for name in EVAL_MATERIALS:
        mount(name, webgl_exports(name))
        fresnels = ["one", "per-point"] + (["eta-k"] if name == "chi5" else []) if name in FRESNEL_MATERIALS else ["one"]
        add_evals(name, materials / name, MODES, fresnels)
    # evalPoints' batches: 65,537 points are one full 256 x 256 draw and one of a single point
    mount("batch", webgl_exports("chi5"))
    add_evals("batch", materials / "chi5", [("exact", "single")], ["one"], n=BATCH + 1)

    # sampling: (wi, lambda0, xi1, xi2, eta, k, wo given, 0); eta 0 is F = 1 (the layered models use their interface's)
    for name in SAMPLE_MATERIALS:
        m = params_of(materials / name)
        x = points(rng, m, N_SAMPLE)
        conductor = m.get("model", "conductor") == "conductor"
        inp = f32(np.concatenate([x[:, 0:3], x[:, 6:7], rng.random((N_SAMPLE, 2)), x[:, 7:9] if conductor else np.zeros((N_SAMPLE, 2)),
                                  x[:, 3:6], np.zeros((N_SAMPLE, 1))], 1))
        inp.astype(np.float32).tofile(data / f"{name}.samples.bin")
        for lobe, energy in MODES:
            brdf = CBrdf(materials / name, lobe, c_cache, energy=energy)
            jid = f"{name} {lobe} {energy}"
            case["samples"].append({"id": jid, "material": name, "lobe": lobe, "energy": energy, "inputs": f"/data/{name}.samples.bin"})
            wi, lam = inp[:, 0:3], inp[:, 3]
            fr = {"eta": inp[:, 6], "k": inp[:, 7]} if conductor else {}
            wo, pdf, weight = brdf.sample(wi, lam, inp[:, 4], inp[:, 5], **fr)
            ref["samples"][jid] = (wo, pdf, weight, brdf.pdf(wi, inp[:, 8:11], lam))

    # a scene bundle, unpacked (tarfile), one material folder of it exported for the GPU
    unpacked = data / "bundle"
    with tarfile.open(bundle) as tar:
        members = [t for t in tar.getmembers() if f"/{BUNDLE_MATERIAL}/" in t.name]
        tar.extractall(unpacked, members=members, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    folder = next(unpacked.glob(f"*/{BUNDLE_MATERIAL}"))
    mount("bundle", export_webgl(folder, data / "bundle-webgl"))
    add_evals("bundle", folder, [("exact", "compensated"), ("fit", "single")], ["one"])

    # broken exports of chi1: a flipped byte, a truncated binary, a missing one, a bad descriptor, a changed
    # number in a valid descriptor (only SHA256SUMS covers it), no SHA256SUMS
    good = webgl_exports("chi1")
    for what in ("corrupted", "truncated", "missing", "json", "descriptor", "sums"):
        bad = shutil.copytree(good, data / f"bad-{what}")
        desc = json.loads((bad / "material.json").read_text())
        if what == "corrupted":
            b = bytearray((bad / "epd_sampling.bin").read_bytes())
            b[1000] ^= 0x40
            (bad / "epd_sampling.bin").write_bytes(b)
            expect = "epd_sampling.bin: SHA-256 mismatch (expected "
        elif what == "truncated":
            b = (bad / "albedo.bin").read_bytes()
            (bad / "albedo.bin").write_bytes(b[:-8])
            expect = f"albedo.bin: truncated: {len(b) - 8} bytes, expected {len(b)}"
        elif what == "missing":
            desc["tables"][0]["file"] = "missing.bin"
            (bad / "material.json").write_text(json.dumps(desc))
            expect = "missing.bin: HTTP 404"
        elif what == "json":
            (bad / "material.json").write_text(json.dumps(desc)[:-10])
            expect = "material.json: not valid JSON ("
        elif what == "descriptor":
            text = (bad / "material.json").read_text()
            (bad / "material.json").write_text(text.replace(f'"beta": {desc["material"]["beta"]}', f'"beta": {desc["material"]["beta"] * 1.01}', 1))
            assert (bad / "material.json").read_text() != text
            expect = "material.json: SHA-256 mismatch (SHA256SUMS has "
        else:
            (bad / "SHA256SUMS").unlink()
            expect = "SHA256SUMS: HTTP 404"
        case["rejects"].append({"id": what, "url": f"/data/bad-{what}/material.json"})
        ref["rejects"][what] = expect

    (data / "case.json").write_text(json.dumps(case))
    with Server(mounts) as srv:
        t = time.time()
        page = run_page(srv.url("/runtime/tests/harness.html?case=/data/case.json"), budget_ms=60000, timeout=300)
        seconds = time.time() - t
    status = page.text("status")
    assert status == "done", f"harness page: {status!r}; console: {page.console[-20:]}"
    errors = [line for line in page.console if "rror" in line]
    assert not errors, f"console errors: {errors[:10]}"
    print(f"harness page: {seconds:.1f} s (Chromium start, loading, compiling and running every case)")
    yield json.loads(page.text("result")), ref


def eval_report(results, refs, prefix=""):
    lines, failed = [], []
    for jid, c in refs.items():
        if not jid.startswith(prefix):
            continue
        gpu = decode(results[jid])
        rel, below, i = worst(gpu, c)
        lines.append(f"  {jid:40s} worst rel {rel:.2e} (c {c[i]:.3e}, gpu {gpu[i]:.3e}); below the floor {below:.2e} of it")
        if not (rel <= TOL and below <= TOL):
            failed.append(jid)
    return lines, failed


def test_webgl_brdf_eval_against_c(webgl_run):
    results, ref = webgl_run
    evals = {k: v for k, v in ref["evals"].items() if not k.startswith("bundle")}
    lines, failed = eval_report(results, evals)
    report(not failed, f"ts_eval (evalPoints) against the C BRDF, {N_EVAL} points each, criterion {TOL:g} relative where "
                       f"c >= {FLOOR:g} max c:\n" + "\n".join(lines) + (f"\nfailed: {failed}" if failed else ""))


def test_webgl_brdf_bundle_eval(webgl_run):
    results, ref = webgl_run
    lines, failed = eval_report(results, ref["evals"], "bundle")
    assert lines
    report(not failed, f"evalPoints on {BUNDLE_MATERIAL} of a scene bundle against the C BRDF on the unpacked folder:\n" + "\n".join(lines))


def test_webgl_brdf_sample_against_c(webgl_run):
    results, ref = webgl_run
    lines, failed = [], []
    for jid, (wo_c, pdf_c, w_c, pdf_given_c) in ref["samples"].items():
        out = decode(results[jid]).reshape(-1, 8)
        wo_g, pdf_g, w_g, pdf_at_g, pdf_given_g = out[:, 0:3], out[:, 3], out[:, 4], out[:, 5], out[:, 6]
        kept = (pdf_c > 0) & (pdf_g > 0)
        lost = int(((pdf_c > 0) != (pdf_g > 0)).sum())  # lost by one and not the other
        pdf_c, w_c, pdf_g = np.where(kept, pdf_c, 1.0), np.where(kept, w_c, 1.0), np.where(kept, pdf_g, 1.0)
        d_wo = float(np.abs(wo_g - wo_c)[kept].max())
        sig = kept & (pdf_c >= FLOOR * pdf_c.max())
        r_pdf = float((np.abs(pdf_g - pdf_c) / pdf_c)[sig].max())
        rel_w = np.where(sig & (w_c > 0), np.abs(w_g - w_c) / np.maximum(np.abs(w_c), 1e-300), 0.0)
        r_w, cos_w = float(rel_w.max()), float(wo_c[np.argmax(rel_w), 2])  # (a grazing wo carries wo's error into cos_o)
        r_self = float((np.abs(pdf_at_g - pdf_g) / pdf_g)[kept].max())  # ts_pdf at ts_sample's wo = its pdf
        sig_g = pdf_given_c >= FLOOR * pdf_given_c.max()
        r_given = float((np.abs(pdf_given_g - pdf_given_c)[sig_g] / pdf_given_c[sig_g]).max())
        lines.append(f"  {jid:32s} {int(kept.sum())} kept, {lost} lost by one only; |wo - wo_c| {d_wo:.1e}; rel: pdf {r_pdf:.1e}, "
                     f"weight {r_w:.1e} (cos_o {cos_w:.1e}), ts_pdf at wo {r_self:.1e}, ts_pdf at given wo {r_given:.1e}")
        if not (lost == 0 and d_wo <= 1e-4 and r_pdf <= TOL and r_w <= TOL and r_self <= 1e-5 and r_given <= TOL):
            failed.append(jid)
    report(not failed, f"ts_sample / ts_pdf against the C BRDF, {N_SAMPLE} samples each (wo within 1e-4, pdf and weight "
                       f"within {TOL:g} where pdf >= {FLOOR:g} max):\n" + "\n".join(lines) + (f"\nfailed: {failed}" if failed else ""))


def test_webgl_load_rejects_broken_exports(webgl_run):
    results, ref = webgl_run
    lines, failed = [], []
    for what, expect in ref["rejects"].items():
        got = results[what].get("rejected")
        lines.append(f"  {what}: {got}")
        if not (got and got.startswith(expect)):
            failed.append(f"{what}: expected {expect!r}")
    report(not failed, "loadMaterial rejects:\n" + "\n".join(lines) + (f"\nfailed: {failed}" if failed else ""))


def test_webgl_brdf_eval_against_mitsuba(webgl_run, variant_llvm_ad_spectral, materials):
    """evalPoints against the Mitsuba BSDF itself (not only through the C BRDF) at the eval test's points, F = 1."""
    import drjit as dr
    import mitsuba as mi
    import twoscale_mitsuba  # noqa: F401  (registers the plugin)

    results, ref = webgl_run
    lines, failed = [], []
    for name in MITSUBA_MATERIALS:
        x = ref["points"][name]
        wi, wo, lam = x[:, 0:3], x[:, 3:6], x[:, 6]
        up = (wi[:, 2] > 0) & (wo[:, 2] > 0)  # Mitsuba's eval is 0 below the surface, as ts_eval's
        for lobe, energy in MODES:
            d = {"type": "twoscale", "tables": str(materials / name), "lobe": lobe, "energy": energy}
            if params_of(materials / name).get("model", "conductor") == "conductor":
                d["fresnel"] = "one"
            bsdf = mi.load_dict(d)
            si = dr.zeros(mi.SurfaceInteraction3f, len(x))
            si.wi = mi.Vector3f(*[mi.Float(wi[:, j].astype(np.float32)) for j in range(3)])
            si.wavelengths = mi.Spectrum(mi.Float((1e3 * lam).astype(np.float32)))
            v = bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*[mi.Float(wo[:, j].astype(np.float32)) for j in range(3)]))
            want = np.where(up, np.asarray(v[0], np.float64) / np.where(up, wo[:, 2], 1.0), 0.0)
            gpu = decode(results[f"{name} {lobe} {energy} one"])
            rel, below, i = worst(gpu, want)
            lines.append(f"  {name} {lobe} {energy}: worst rel {rel:.2e} (mitsuba {want[i]:.3e}, gpu {gpu[i]:.3e}); below the floor {below:.2e}")
            if not (rel <= TOL and below <= TOL):
                failed.append(f"{name} {lobe} {energy}")
    report(not failed, f"evalPoints against the Mitsuba BSDF (llvm_ad_spectral), {N_EVAL} points each, criterion {TOL:g} relative where "
                       f"rho >= {FLOOR:g} max:\n" + "\n".join(lines) + (f"\nfailed: {failed}" if failed else ""))
