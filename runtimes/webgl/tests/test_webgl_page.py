"""The BRDF explorer (runtimes/webgl/index.html + explorer.js) in headless Chromium (SwiftShader's WebGL2).
Three Chromium runs; tests/page_cases.html opens the explorer in one iframe per case. `pytest -rP runtimes/webgl
-k page` prints the figures:

  draws    one --screenshot run, the explorer on chi5 (a diffracting conductor), plastic7 (a coloured plastic) and
           plastic1 (a white one) side by side: each gets ready with every view drawn and no error, and in the
           screenshot its sphere canvas holds many non-background pixels of varying values; Chromium logged no
           console line (no console.* call, no uncaught error, no failed load) but the GL driver's note that
           readPixels stalls the GPU; the albedo curve is 1 where it must be (plastic1 in both energy modes, chi5
           compensated with F = 1): the page's quadrature on the GPU's rho;
  controls in the same run, a fourth explorer on chi5 whose energy control is then set to compensated, and then
           its lobe control to fit, as a user would: each redraw shows the new mode (the sphere's program is
           compiled for the modes, so a stale one would draw the old mode silently);
  broken   one --dump-dom run: a corrupted, a truncated and a missing binary and a descriptor that is not JSON
           each show one line naming the file, and nothing is drawn; loadMaterial rejects each, naming the file;
  view     `twoscale view FOLDER`: the printed URL serves the explorer, which gets ready.
  general  the explorer on the general export (?tables=): each of the sliders beta, p, sigma_s, b, c, eta and k
           moved as a user would redraws every panel (the sphere under the point light, and the polar plot, the
           slice and the albedo pixel for pixel against before the move); the beta map redraws the sphere; the
           page shows the query that reproduces the view.
"""
import json
import math
import queue
import re
import shutil
import struct
import subprocess
import threading
import time
import zlib
from pathlib import Path
from urllib.parse import quote

import pytest
from browser import Server, export_webgl, run_page
from twoscale_c import twoscale_binary

WEBGL = Path(__file__).resolve().parent.parent
# Chromium's note that readPixels stalls the (software) GPU, once a context: not the page's. Any other GL driver
# message (an error, another performance warning) counts.
BENIGN = re.compile(r"GL Driver Message \(OpenGL, Performance, \w+, \w+\): GPU stall due to ReadPixels")


@pytest.fixture(scope="session")
def page_exports(materials, tmp_path_factory):
    """name -> the folder of that test material's `twoscale export --format webgl` (exported once)."""
    root, done = tmp_path_factory.mktemp("webgl-page"), {}

    def get(name):
        if name not in done:
            done[name] = export_webgl(materials / name, root / name)
        return done[name]

    return get


def png_rgb(path, top=1.0):
    """(width, height, rows): an 8-bit RGB or RGBA PNG (what Chromium writes) decoded, rows of (r, g, b) tuples;
    only the top fraction of the rows (the filters chain rows from the top; plain Python takes ~1 s a megapixel)."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat, head = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, ctype, _, _, interlace = head
    assert depth == 8 and ctype in (2, 6) and interlace == 0, f"{path}: unexpected PNG format {head}"
    bpp = 3 if ctype == 2 else 4
    raw, stride, rows, prev = zlib.decompress(idat), w * bpp, [], bytearray(w * bpp)
    for y in range(round(top * h)):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):  # PNG's filters: None, Sub, Up, Average, Paeth
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], (prev[i - bpp] if i >= bpp else 0)
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, rows


def grey_stats(rows, rect):
    """Within rect (x, y, w, h) of decoded rows: (pixels differing from the panel's colour #1f2226, which is the
    sphere canvas' background too, their mean grey, its standard deviation)."""
    x, y, w, h = rect
    bg = (31, 34, 38)
    vals = [sum(p) / 3 for row in rows[y:y + h] for p in row[x:x + w] if sum(abs(c - d) for c, d in zip(p, bg)) > 12]
    mean = sum(vals) / max(len(vals), 1)
    return len(vals), mean, (sum((v - mean) ** 2 for v in vals) / max(len(vals), 1)) ** 0.5


def run_cases(srv, cases, budget_ms, **kwargs):
    """tests/page_cases.html on cases in one Chromium run, given its budget (its waits end 10 s before)."""
    url = srv.url(f"/tests/page_cases.html?budget={budget_ms}&cases=" + quote(json.dumps(cases)))
    return run_page(url, budget_ms=budget_ms, **kwargs)


GOOD = ["chi5", "plastic7", "plastic1"]
# chi5 under the point light alone: the sphere is then deterministic (no sky samples), all of it drawn by the
# BRDF program of the modes; energy, then lobe, set as a user would
CONTROLS = {"id": "controls", "material": "/m/chi5/material.json", "query": "spp=2&theta=40&light=point",
            "steps": [{"energy": "compensated"}, {"lobe": "fit"}]}


@pytest.fixture(scope="module")
def good_run(page_exports, tmp_path_factory):
    """The explorer on GOOD and CONTROLS side by side, one --screenshot run; the page's results come through the
    console (its PAGE_CASES line). (results, the screenshot's decoded rows, the other console lines)."""
    mounts = {f"/m/{n}/": page_exports(n) for n in GOOD}
    mounts["/"] = WEBGL
    cases = [{"id": n, "material": f"/m/{n}/material.json", "query": "spp=2&theta=40"} for n in GOOD] + [CONTROLS]
    shot = tmp_path_factory.mktemp("webgl-shot") / "page_cases.png"
    t0 = time.monotonic()
    with Server(mounts) as srv:
        page = run_cases(srv, cases, budget_ms=120000, size=(640 * len(cases), 600), timeout=240, screenshot=shot)
    line = next((c for c in page.console if "PAGE_CASES {" in c), None)
    assert line, f"the case page reported nothing; console: {page.console[-10:]}"
    res = json.loads(line[line.index("PAGE_CASES {") + 11:line.rindex("}") + 1])
    bottom = max(r["sphere_rect"][1] + r["sphere_rect"][3] for r in res.values() if "sphere_rect" in r)
    _, _, rows = png_rgb(shot, top=min(1.0, (bottom + 1) / 600))
    others = [c for c in page.console if not BENIGN.search(c) and "PAGE_CASES {" not in c]
    print(f"page_cases.html: {len(cases)} explorers in {time.monotonic() - t0:.1f} s")
    return res, rows, others


@pytest.mark.parametrize("name", GOOD)
def test_webgl_page_draws(good_run, name):
    res, rows, _ = good_run
    r = res[name]
    assert not r.get("timeout"), f"{name}: not ready in time"
    s = r["status"]
    assert r["ready"] == "1" and s["ready"] and not s["errors"] and not r["error_shown"], f"{name}: {r}"
    assert all(s["drawn"].get(k) for k in ("sphere", "polar", "slice", "albedo")), s["drawn"]
    n, mean, std = grey_stats(rows, r["sphere_rect"])
    print(f"{name}: screenshot: {n} sphere pixels, grey mean {mean:.1f}, std {std:.1f}; the page's count: {s['sphere']}")
    # the disk spans 92 % of the canvas' shorter side: pi / 4 0.92^2 = 66 % of a square
    assert n > 0.5 * min(r["sphere_rect"][2:]) ** 2 > 5000 and std > 10, f"{name}: the sphere drew {n} pixels (std {std:.1f})"
    assert s["sphere"]["non_background"] > 0.9 * s["sphere"]["pixels"] and s["sphere"]["std"] > 5, s["sphere"]


def test_webgl_page_console(good_run):
    """Chromium logged no console line for the pages (no console.*, no uncaught error, no failed load, no GL error,
    also after the controls changed), but its note that readPixels stalls the GPU."""
    assert not good_run[2], good_run[2]


def test_webgl_page_albedo(good_run):
    """The albedo curve's quadrature on known cases: a white diffuse layer under a clear coat (plastic1) reflects
    everything in both energy modes (the C BRDF: 1 to 1e-5; the page: 5e-6); chi5 compensated with F = 1 too (the
    C BRDF's own furnace error: 2e-4; the page: 3.9e-4)."""
    res, worst, limit = good_run[0], {}, {}
    for name, modes, tol in (("plastic1", ("single", "compensated"), 5e-5), ("chi5", ("compensated",), 1e-3)):
        a = res[name]["status"]["albedo"]
        for mode in modes:
            worst[f"{name} {mode}"] = max(abs(v - 1) for v in a[mode])
            limit[f"{name} {mode}"] = tol
    print("largest |albedo - 1| over 24 angles 0-88 deg at 0.55 um: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    assert all(worst[k] <= limit[k] for k in worst), f"largest |albedo - 1| {worst}, limits {limit}"


def res_ok(res, name):
    """The case's result, ready with no error."""
    r = res[name]
    assert not r.get("timeout"), f"{name}: not ready in time"
    assert r["ready"] == "1" and r["status"]["ready"] and not r["status"]["errors"], f"{name}: {r}"
    return r


def test_webgl_page_controls(good_run):
    """Setting the energy control, then the lobe control, as a user would (the input checked, 'input' and 'change'
    dispatched) redraws every view in the new mode. chi5 under the point light alone: the sphere is deterministic,
    so its mean moves only with the BRDF (by 5.7 grey levels to compensated, 2.8 to fit; 8-bit rounding: 0.01).
    The albedo panel always draws both energy curves (the energy control only marks one): the energy step leaves
    both as they were, each its mode's (compensated 1 within 1e-3 with F = 1, single 13 % off); the lobe step
    changes them (fit against exact, up to 8e-3). The polar plot follows both (compensated adds energy to its
    peak; the fit lobe differs in its tails)."""
    r = res_ok(good_run[0], "controls")
    steps = r.get("steps") or []
    for st in steps:
        assert not st.get("error"), st["error"]
        why = "the page redrew but the sphere was not done" if st.get("redrawn") else "the page did not redraw (#status-json unchanged)"
        assert not st.get("timeout"), f"after setting {st['set']}: {why}"
    assert len(steps) == 2, f"steps run: {steps}"
    s0, s1, s2 = r["status"], steps[0]["status"], steps[1]["status"]
    for st in steps:
        assert st["status"]["ready"] and not st["status"]["errors"], f"after setting {st['set']}: {st['status']['errors']}"
    mean = [s["sphere"]["mean"] for s in (s0, s1, s2)]
    polar = [s["polar"]["max"] for s in (s0, s1, s2)]
    alb = [{e: s["albedo"][e] for e in ("single", "compensated")} for s in (s0, s1, s2)]
    dev = [{e: max(abs(v - 1) for v in a[e]) for e in a} for a in alb]
    lobe_diff = max(abs(x - y) for e in ("single", "compensated") for x, y in zip(alb[1][e], alb[2][e]))
    print(f"exact single -> exact compensated -> fit compensated: sphere mean {mean[0]} -> {mean[1]} -> {mean[2]}, "
          f"polar max {polar[0]:.5g} -> {polar[1]:.5g} -> {polar[2]:.5g}, polar pixels changed "
          f"{steps[0]['changed_px']['polar']}, {steps[1]['changed_px']['polar']}; largest |albedo - 1| single "
          f"{dev[1]['single']:.3f}, compensated {dev[1]['compensated']:.1e}; fit against exact albedo {lobe_diff:.1e}")
    # energy: the sphere (the BRDF program of the new mode) brighter, the polar plot redrawn, the curves each their mode's
    assert mean[1] > mean[0] + 1, f"energy compensated: the sphere's mean went {mean[0]} -> {mean[1]}: the old mode drawn?"
    assert polar[1] > polar[0] * (1 + 1e-3) and steps[0]["changed_px"]["polar"] > 0, \
        f"energy compensated: polar max {polar[:2]}, pixels changed {steps[0]['changed_px']}"
    assert alb[1] == alb[0], "energy compensated: the albedo curves changed (both modes are always drawn)"
    assert dev[1]["compensated"] <= 1e-3 < 0.05 < dev[1]["single"], f"the albedo curves are not their modes': {dev[1]}"
    # lobe: the sphere, the polar plot and the curves in the fit lobe
    assert abs(mean[2] - mean[1]) > 1, f"lobe fit: the sphere's mean went {mean[1]} -> {mean[2]}: the old lobe drawn?"
    assert steps[1]["changed_px"]["polar"] > 0 and polar[2] != polar[1], \
        f"lobe fit: the polar plot did not change: max {polar[1:]}, pixels changed {steps[1]['changed_px']}"
    assert lobe_diff > 1e-3, f"lobe fit: the albedo curves moved by {lobe_diff:.1e} only: still the exact lobe's?"


def _break(src, out, how):
    """A copy of the export src in out, broken one way; the file the error must name."""
    shutil.copytree(src, out)
    desc = json.loads((out / "material.json").read_text())
    if how == "corrupt":  # one byte flipped: same size, another SHA-256
        f = out / "epd_g1.bin"
        b = bytearray(f.read_bytes())
        b[len(b) // 2] ^= 0x40
        f.write_bytes(bytes(b))
        return f.name
    if how == "truncated":
        f = out / "zh_lobe.bin"
        f.write_bytes(f.read_bytes()[:-1000])
        return f.name
    if how == "missing":  # the descriptor names a file the export lacks
        desc["tables"][0]["file"] = "no_such_table.bin"
        (out / "material.json").write_text(json.dumps(desc))
        return "no_such_table.bin"
    (out / "material.json").write_text('{"format": "twoscale-webgl/1", "tables": [')  # not JSON
    return "material.json"


BROKEN = ["corrupt", "truncated", "missing", "not_json"]


@pytest.fixture(scope="module")
def page_cases(page_exports, tmp_path_factory):
    """The broken exports in one --dump-dom run of tests/page_cases.html: ({id: result}, {id: the file to name})."""
    root = tmp_path_factory.mktemp("webgl-cases")
    names = {how: _break(page_exports("chi5"), root / how, how) for how in BROKEN}
    cases = [{"id": how, "material": f"/cases/{how}/material.json", "load": True} for how in BROKEN]
    t0 = time.monotonic()
    with Server({"/cases/": root, "/": WEBGL}) as srv:
        page = run_cases(srv, cases, budget_ms=30000, timeout=120)
    text = page.text("result")
    assert text, f"the case page wrote no result; console: {page.console[-10:]}"
    print(f"page_cases.html: {len(cases)} broken exports in {time.monotonic() - t0:.1f} s")
    return json.loads(text), names


@pytest.mark.parametrize("how", BROKEN)
def test_webgl_page_broken_export(page_cases, how):
    res, names = page_cases
    r, name = res[how], names[how]
    assert not r.get("timeout"), f"{how}: the page neither failed nor got ready"
    s = r["status"]
    assert r["error_shown"] and name in r["error"] and "\n" not in r["error"].strip(), f"{how}: error line {r['error']!r}"
    assert not s["ready"] and not any(s["drawn"].values()) and r["ready"] is None, f"{how}: {s}"
    assert r["load"]["rejected"] and name in r["load"]["message"], f"{how}: loadMaterial {r['load']}"
    print(f"{how}: {r['error']}")


def test_webgl_page_twoscale_view(materials, tmp_path):
    """`twoscale view FOLDER` prints a URL within 30 s that serves the explorer, which gets ready."""
    err = tmp_path / "view.stderr"
    with open(err, "w") as f:
        proc = subprocess.Popen([twoscale_binary(), "view", str(materials / "plastic7")], stdout=subprocess.PIPE,
                                stderr=f, text=True)
    try:
        lines = queue.Queue()
        threading.Thread(target=lambda: lines.put(proc.stdout.readline()), daemon=True).start()
        try:
            line = lines.get(timeout=30)
        except queue.Empty:
            line = None
        assert line is not None, f"twoscale view printed no line in 30 s; its stderr: {err.read_text()[-2000:]!r}"
        m = re.search(r"http://127\.0\.0\.1:\d+/\S*", line)
        assert m, f"twoscale view printed {line!r}; its stderr: {err.read_text()[-2000:]!r}"
        url = m.group(0)
        page = run_page(url + ("&" if "?" in url else "?") + "spp=2", budget_ms=30000, size=(900, 600))
    finally:
        proc.kill()
        proc.wait()
    s = json.loads(page.text("status-json") or "{}")
    assert s.get("ready") and not s.get("errors"), f"{url}: {s}; console {page.console[-5:]}; view's stderr {err.read_text()[-2000:]!r}"


# The sliders of the general explorer: a log slider (beta, p, b) takes ln of the value.
GENERAL_STEPS = [{"beta": math.log(0.2)}, {"p": math.log(2.5)}, {"sigma_s": 0.1}, {"b": math.log(4.0)}, {"c": 1.5},
                 {"eta": 0.5}, {"kappa": 1.0}, {"map": "beta"}]


def test_webgl_page_general_sliders(tables, tmp_path):
    """Every slider of the general explorer redraws every panel: the sphere (point light: deterministic, so its mean
    or spread moves only with the BRDF) and each plot's pixels; the map redraws the sphere alone."""
    out = tmp_path / "general"
    res = subprocess.run([twoscale_binary(), "export", "--format", "webgl", "--preset", "default", "--tables", str(tables.parent),
                          "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    query = "spp=2&theta=40&light=point&beta=0.08&p=1.2&sigma_s=0.02&b=1.5&c=2.2&fresnel=conductor&eta=1.8&kappa=3.2"
    cases = [{"id": "general", "tables": "/g/tables.json", "query": query, "steps": GENERAL_STEPS}]
    with Server({"/g/": out, "/": WEBGL}) as srv:
        page = run_cases(srv, cases, budget_ms=180000, timeout=400)
    r = res_ok(json.loads(page.text("result")), "general")
    steps = r.get("steps") or []
    lines, ok = [], len(steps) == len(GENERAL_STEPS)
    prev = r["status"]
    for st in steps:
        if st.get("timeout") or st.get("error"):
            lines.append(f"  {st['set']}: {st.get('error') or 'no redraw'} (status {json.dumps(st.get('status'))[:400]})")
            ok = False
            break
        s0, s1 = prev["sphere"], st["status"]["sphere"]
        sphere = (s0["mean"], s0["std"]) != (s1["mean"], s1["std"])
        px = st["changed_px"]
        plots = all(px[k] > 0 for k in ("polar", "slice", "albedo"))
        want_plots = "map" not in st["set"]
        ok &= sphere and (plots if want_plots else True) and st["status"]["ready"] and not st["status"]["errors"]
        lines.append(f"  {st['set']}: sphere mean {s0['mean']} -> {s1['mean']}, std {s0['std']} -> {s1['std']}; plot pixels changed {px}")
        prev = st["status"]
    print("general: the sliders and the map, each set as a user would:\n" + "\n".join(lines))
    assert ok, "a slider did not redraw every panel"
    url = r.get("url", "")
    print(f"  the page's query: {url}")
    assert url.startswith("?tables=/g/tables.json&beta=0.2&p=2.5&sigma_s=0.1&b=4&c=1.5") and "eta=0.5&kappa=1" in url and "map=beta" in url, \
        f"the page does not show the query of its view: {url!r}"
