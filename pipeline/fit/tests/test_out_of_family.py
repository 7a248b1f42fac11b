"""`twoscale fit --compare` on files outside the two-scale family (issue 63; runtimes/testing/out_of_family.py).

- A GGX metal over a dark Lambertian base, which no two-scale model fits exactly, with `--compare` (the three two-scale
  models, as `--model auto`, and the comparison models): the conductor is chosen; no model ends worse than rho = 0
  (relative RMS above 1: a plastic capped at ior 3 did, overshooting the grazing mirror samples); `comparison` has
  exactly its keys and the six models; ggx_lambert, whose own file this is, recovers it; and `at_bounds` lists exactly
  the chosen fit's parameters within 1 % of an end of their range (in their fitted coordinate), checked against the
  values it reports, b among them (the diffraction term standing in for the base).
- The Beckmann and EPD coats over the same base: beckmann_lambert and epd_lambert each recover their own file, to the
  parameters.

    pytest pipeline/fit/tests/test_out_of_family.py --tables tables-out/default     (about 30 s on 2 cores)"""
import json
import math
import subprocess

import out_of_family
import pytest
from twoscale_c import twoscale_binary

COMPARISON_KEYS = {"model", "parameters", "log_rms", "relative_rms", "seconds"}
# model: its number of parameters (a two-scale model's without diffraction, with it)
PARAMETERS = {"twoscale_conductor": (8, 11), "twoscale_plastic": (6, 9), "twoscale_subsurface": (7, 10),
              "ggx_lambert": (10,), "beckmann_lambert": (10,), "epd_lambert": (11,)}


def fit(path, tmp_path, tables, *args):
    cmd = [twoscale_binary(), "fit", str(path), "--out", str(tmp_path / "fit.toml"), "--tables", str(tables.parent),
           "--samples", "10000", "--json", *args]
    res = subprocess.run(cmd, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout), res.stderr


def test_a_metal_over_a_lambertian_base_compared(tables, tmp_path):
    result, log = fit(out_of_family.write("ggx_conductor_lambert", tmp_path), tmp_path, tables, "--compare")
    rows = {r["model"]: r for r in result["comparison"]}
    print("\n".join(f"{r['model']:20} {r['parameters']:3} {r['log_rms']:.4f} {r['relative_rms']:.4f} {r['seconds']:.1f} s"
                    for r in result["comparison"]))
    assert [r["model"] for r in result["comparison"]] == list(PARAMETERS)
    assert all(set(r) == COMPARISON_KEYS for r in result["comparison"]), result["comparison"]
    assert all(r["parameters"] in PARAMETERS[r["model"]] for r in result["comparison"]), result["comparison"]
    assert result["model"] == "conductor", result["comparison"]
    # the chosen model's count is that of the candidate written: with diffraction where sigma_s > 0
    assert rows["twoscale_conductor"]["parameters"] == (11 if result["material"]["sigma_s"] > 0 else 8)
    assert all(r["relative_rms"] <= 1.0 for r in result["comparison"]), "a model worse than rho = 0"
    assert rows["twoscale_conductor"]["relative_rms"] < 0.25
    assert rows["ggx_lambert"]["relative_rms"] <= 1e-3, "ggx_lambert does not recover its own file"
    assert all(c["loss"] is not None and not c["termination"].startswith("User") for c in result["candidates"])
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
    assert "conductor: with diffraction: at the end of their range: " in log and "b = 0.06500 (lower end" in log, log
    assert "stands in for a diffuse or constant term: `--model plastic` may fit better" in log, log


@pytest.mark.parametrize("model, name", [("beckmann_lambert", "beckmann_conductor_lambert"),
                                         ("epd_lambert", "epd_conductor_lambert")])
def test_a_comparison_model_recovers_its_own_file(tables, tmp_path, model, name):
    result, _ = fit(out_of_family.write(name, tmp_path), tmp_path, tables, "--compare", "--model", "conductor")
    assert [r["model"] for r in result["comparison"]] == ["twoscale_conductor", "ggx_lambert", "beckmann_lambert", "epd_lambert"]
    row = next(r for r in result["comparison"] if r["model"] == model)
    print(result["comparison"])
    assert row["relative_rms"] <= 1e-3, row
    # to the parameters: the lobe's, and eta, k and kd per channel
    _, lobe, (_, eta, k), kd, _ = out_of_family.MATERIALS[name]
    fitted = result["compared"][model]
    got = [fitted["material"][n] for n in (("beta", "p") if model == "epd_lambert" else ("alpha",))]
    got += [c[q] for q in ("eta", "k", "kd") for c in fitted["channels"]]
    want = [*lobe, *eta, *k, *kd]
    assert all(abs(g - w) <= 2e-3 * w for g, w in zip(got, want)), (got, want)


AT_END = 0.01
# name: (lo, hi, logarithmic): the fitted parameters' ranges (docs/fit.md "The method")
RANGES = {"beta": (0.005, 0.5, True), "p": (0.2, 5.0, True), "sigma_s": (1e-5, 1.0, True), "b": (0.1 * 0.65, 30 * 0.45, True),
          "c": (1.02, 3.02, False), "eta": (1e-3, 100.0, True), "k": (1e-5, 100.0, True)}


def fraction(name, v):
    """Where v lies in its range, 0 to 1, in the scale its coordinate moves it."""
    lo, hi, log = RANGES[name]
    return math.log(v / lo) / math.log(hi / lo) if log else (v - lo) / (hi - lo)
