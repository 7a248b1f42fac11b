"""`twoscale fit --model auto` on files outside the two-scale family (issue 63; runtimes/testing/out_of_family.py): a GGX
metal over a dark Lambertian base, whose file no candidate fits exactly. The conductor must be chosen; every
candidate must end with a finite loss; and what the plastic cannot do must be said, not left silent: its
interface's ior pinned at the upper end of its range (a dielectric's F0 is at most 0.25 there, a metal's 0.6), and
its relative RMS above 1 (it overshoots the grazing mirror samples, which hold most of sum t^2) flagged with the log
RMS it is fitted in, far below rho = 0's. The JSON's `at_bounds` lists exactly the chosen fit's parameters within 1 %
of an end of their range (in their fitted coordinate): checked here against the values it reports.

    pytest pipeline/fit/tests/test_out_of_family.py --tables tables-out/default     (about 60 s on 2 cores)"""
import json
import math
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
    # at_bounds lists exactly the parameters within 1 % of an end of their range, in their fitted coordinate: computed
    # here from the reported values and docs/fit.md's ranges (b's: B = b / lambda in [0.1, 30] at every channel)
    assert all(set(a) == {"name", "value", "bound"} for a in result["at_bounds"]), result["at_bounds"]
    m, expected = result["material"], set()
    params = [("beta", m["beta"]), ("p", m["p"])]
    if m["sigma_s"] > 0:  # with diffraction; b and c are not said where sigma_s sits at its lower end
        params.append(("sigma_s", m["sigma_s"]))
        if fraction("sigma_s", m["sigma_s"]) >= AT_END:
            params += [("b", m["b"]), ("c", m["c"])]
    for ch in result["channels"]:
        params += [(f"eta[{ch['channel']}]", ch["eta"]), (f"k[{ch['channel']}]", ch["k"])]
    for name, v in params:
        f = fraction(name.split("[")[0], v)
        if f < AT_END or f > 1 - AT_END:
            expected.add(name)
    said = {a["name"] for a in result["at_bounds"]}
    print(f"at_bounds of the chosen fit: {result['at_bounds']}")
    assert said == expected, f"at_bounds {sorted(said)}, expected {sorted(expected)}"
    assert "b" in said, "this file's diffraction term stands in for the base: b at its lower bound"
    if models["plastic"]["relative_rms"] > 1.0:
        assert "plastic: relative RMS" in log and "worse than rho = 0" in log, log


AT_END = 0.01
# name: (lo, hi, logarithmic): the fitted parameters' ranges (docs/fit.md "The method")
RANGES = {"beta": (0.005, 0.5, True), "p": (0.2, 5.0, True), "sigma_s": (1e-5, 1.0, True), "b": (0.1 * 0.65, 30 * 0.45, True),
          "c": (1.02, 3.02, False), "eta": (1e-3, 100.0, True), "k": (1e-5, 100.0, True)}


def fraction(name, v):
    """Where v lies in its range, 0 to 1, in the scale its coordinate moves it."""
    lo, hi, log = RANGES[name]
    return math.log(v / lo) / math.log(hi / lo) if log else (v - lo) / (hi - lo)
