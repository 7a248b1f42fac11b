"""`twoscale fit --model auto` on files outside the two-scale family (issue 63; runtimes/testing/out_of_family.py): a GGX
metal over a dark Lambertian base, whose file no candidate fits exactly. The conductor must be chosen; every
candidate must end with a finite loss; and what the plastic cannot do must be said, not left silent: its
interface's ior pinned at the upper end of its range (a dielectric's F0 is at most 0.25 there, a metal's 0.6), and
its relative RMS above 1 (it overshoots the grazing mirror samples, which hold most of sum t^2) flagged with the log
RMS it is fitted in, far below rho = 0's. The JSON's `at_bounds` lists exactly the chosen fit's parameters within 1 %
of an end of their range (in their fitted coordinate): checked here against the values it reports.

    pytest pipeline/fit/tests/test_out_of_family.py --tables tables-out/default     (about 60 s on 2 cores)"""
import json
import subprocess

import out_of_family
from twoscale_c import twoscale_binary


def test_a_metal_over_a_lambertian_base_is_fitted_as_a_conductor_and_the_plastic_says_why_it_fails(tables, tmp_path):
    path = out_of_family.write("ggx_conductor_lambert", tmp_path)
    cmd = [twoscale_binary(), "fit", str(path), "--out", str(tmp_path / "fit.toml"), "--tables", str(tables.parent),
           "--model", "auto", "--samples", "10000", "--json"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    result = json.loads(res.stdout)
    models = {m["model"]: m for m in result["models"]}
    print(f"models {result['models']}, {result['seconds']:.1f} s")
    assert result["model"] == "conductor", result["models"]
    assert models["conductor"]["relative_rms"] < 0.25
    assert all(c["loss"] is not None and not c["termination"].startswith("User") for c in result["candidates"])
    log = res.stderr
    assert "plastic: without diffraction: at the end of their range: " in log and "ior = 3.000 (upper end" in log, log
    for a in result["at_bounds"]:  # each within 1 % of its bound: the relative distance bounds that in every scale
        assert set(a) == {"name", "value", "bound"} and abs(a["value"] - a["bound"]) <= 0.05 * abs(a["bound"]) + 1e-12, a
    print(f"at_bounds of the chosen fit: {result['at_bounds']}")
    if models["plastic"]["relative_rms"] > 1.0:
        assert "plastic: relative RMS" in log and "worse than rho = 0" in log, log
