"""The explorer's albedo panel (explorer/albedo.js's rule on the GPU's rho), against the albedo tables' own
integration (the Rust builder's, maths.md section 9): which of the model, the compensation and the plot makes a
curve rise above 1. `pytest -rP runtimes/webgl -k explorer_albedo` prints the figures.

  without  the general export, F = 1, no diffraction, a (beta, p) grid over the sliders' domain, 0-88 degrees:
           the single curve is `epd_albedo` (read by the Python reader) within 1e-3, the compensated one 1 within
           1e-3; no curve above 1 + 1e-3 and no note.
  with     three diffracting test materials' own exports at 0.55 um: the single curve is the material folder's
           `albedo` table (`e`, integrated by the builder's adaptive rule) within 1e-4, and it rises above 1 (the
           paper's diffraction part: the BRDF, not the plot), which the panel's note says; compensated stays 1
           within 1e-3. The general export with diffraction (no scale-back in its compensation): the note names it.
"""
import json
from pathlib import Path

import numpy as np
import pytest
from browser import Server, export_webgl, run_page
from checks import report
from test_general_export import export
from twoscale_tables import Table

WEBGL = Path(__file__).resolve().parent.parent
BETAS, PS = (0.005, 0.03, 0.2, 0.5), (0.2, 0.7, 2.5, 5.0)
DIFFRACTING = ("chi6", "chi9", "furnace5")
LAMBDA = 0.55
# The general export with diffraction: sigma_s at the slider's top, where its albedo is well above 1.
DIFFRACTING_GENERAL = {"beta": 0.03, "p": 2.0, "sigma_s": 0.3, "b": 1.5, "c": 3.0}


@pytest.fixture(scope="module")
def albedo_run(tables, materials, tmp_path_factory):
    data = tmp_path_factory.mktemp("explorer-albedo")
    export(tables, data / "general")
    for name in DIFFRACTING:
        export_webgl(materials / name, data / name)
    both = ["single", "compensated"]
    jobs = [{"id": f"plain {beta} {p}", "tables": "/data/general/tables.json", "lambda": LAMBDA, "energies": both,
             "ui": {"beta": beta, "p": p, "sigma_s": 0, "b": 1.5, "c": 2.2}} for beta in BETAS for p in PS]
    jobs += [{"id": name, "material": name, "lambda": LAMBDA, "energies": both} for name in DIFFRACTING]
    jobs.append({"id": "general diffracting", "tables": "/data/general/tables.json", "lambda": LAMBDA, "energies": both,
                 "ui": DIFFRACTING_GENERAL})
    case = {"materials": {name: f"/data/{name}/material.json" for name in DIFFRACTING}, "albedos": jobs}
    (data / "case.json").write_text(json.dumps(case))
    with Server({"/runtime/": WEBGL, "/data/": data}) as srv:
        page = run_page(srv.url("/runtime/tests/harness.html?case=/data/case.json"), budget_ms=300000, timeout=900)
    assert page.text("status") == "done", page.text("status")
    res = json.loads(page.text("result"))
    for job in jobs:
        assert "error" not in res[job["id"]], f"{job['id']}: {res[job['id']]['error']}"
    return res



def test_explorer_albedo_without_diffraction_is_epd_albedo(albedo_run, tables):
    epd = Table.open(tables / "epd_albedo.h5")
    worst, comp, top = (0.0, ""), 0.0, 0.0
    for beta in BETAS:
        for p in PS:
            r = albedo_run[f"plain {beta} {p}"]
            theta = np.radians(r["theta"])
            ref = epd.lookup_arrays({"p": np.full_like(theta, p), "beta": np.full_like(theta, beta), "theta_i": theta})["e"]
            d = np.abs(np.array(r["single"]) - ref)
            if d.max() > worst[0]:
                i = int(d.argmax())
                worst = (float(d.max()), f"beta {beta}, p {p}, {r['theta'][i]:.1f} deg: {r['single'][i]:.5f} against {ref[i]:.5f}")
            comp = max(comp, max(abs(v - 1) for v in r["compensated"]))
            top = max(top, max(r["single"] + r["compensated"]))
            assert r["note"] == "", f"beta {beta}, p {p}: {r['note']}"
    ok = worst[0] <= 1e-3 and comp <= 1e-3 and top <= 1 + 1e-3
    report(ok, f"without diffraction, F = 1, {len(BETAS) * len(PS)} (beta, p), 24 angles 0-88 deg: single against "
               f"epd_albedo {worst[0]:.1e} at most ({worst[1]}); compensated 1 within {comp:.1e}; largest albedo {top:.5f}")
    assert ok, (worst, comp, top)


def test_explorer_albedo_above_one_is_the_models(albedo_run, materials):
    lines, ok = [], True
    for name in DIFFRACTING:
        r = albedo_run[name]
        table = Table.open(materials / name / "albedo.h5")
        point = {"theta_i": np.radians(r["theta"]), "lambda": np.full(len(r["theta"]), LAMBDA)}
        ref = table.lookup_arrays({k: point[k] for k in table.coordinates()})["e"]
        d = float(np.max(np.abs(np.array(r["single"]) - ref)))
        comp = max(abs(v - 1) for v in r["compensated"])
        peak = max(r["single"])
        good = d <= 1e-4 and peak > 1.01 and comp <= 1e-3 and r["note"].startswith("single above 1")
        ok &= good
        lines.append(f"  {name}: single against its albedo table {d:.1e} at most, largest {peak:.4f} at "
                     f"{r['theta'][r['single'].index(peak)]:.0f} deg; compensated 1 within {comp:.1e}; note {r['note']!r}")
    g = albedo_run["general diffracting"]
    general_ok = max(g["compensated"]) > 1.01 and "general tables' compensation" in g["note"]
    lines.append(f"  general export at {DIFFRACTING_GENERAL}: largest single {max(g['single']):.3f}, compensated "
                 f"{max(g['compensated']):.3f}; note {g['note']!r}")
    report(ok and general_ok, f"with diffraction, F = 1, {LAMBDA} um:\n" + "\n".join(lines))
    assert ok and general_ok, "\n".join(lines)
