"""The package's checks and API on a build root (pipeline/contract/golden/make.sh builds one):
outputs without control-variate values, lookup as lookup_arrays on 0-d arrays, broadcasting, domain
errors, and the manifest checks of the contract (old value encodings, the control variates' layout).

    python pipeline/contract/python/tests/test_reader.py BUILD_ROOT

Run by tests/golden.rs; prints one line, exit status 1 with the failures listed.
"""
import copy
import math
import sys
from pathlib import Path

import numpy as np

from twoscale_tables import Table
from twoscale_tables._manifest import check_manifest, check_value_encodings

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)


def raises(f, needle):
    try:
        f()
    except ValueError as e:
        return needle in str(e)
    return False


def main(argv):
    root = Path(argv[1])
    lobe = Table.open(root / "scene-broad_lobe" / "zh_lobe.h5")
    check(lobe.outputs() == ["c_lobe"] and set(lobe.values) == {"c_lobe", "cv_ln_m_s", "cv_b", "cv_epd_core", "cv_tail"}, "zh_lobe's outputs are c_lobe alone")
    pt = {"u": 6.0, "c": 1.95, "p": 0.41, "beta": 0.24, "theta_h": 0.9}
    one = lobe.lookup(pt)
    check(isinstance(one["c_lobe"], float), "lookup returns floats")
    grid = lobe.lookup_arrays({**pt, "theta_h": np.array([[0.0, 0.9], [1.2, math.pi / 2]])})
    check(grid["c_lobe"].shape == (2, 2) and grid["c_lobe"][0, 1] == one["c_lobe"], "lookup_arrays broadcasts and equals lookup")
    zero_d = lobe.lookup_arrays({k: np.float64(v) for k, v in pt.items()})
    check(zero_d["c_lobe"].shape == () and float(zero_d["c_lobe"]) == one["c_lobe"], "0-d arrays give 0-d arrays")
    check(lobe.lookup_arrays({**pt, "u": np.zeros(0)})["c_lobe"].shape == (0,), "no points, no values")
    check(raises(lambda: lobe.lookup_arrays(pt, ["cv_b"]), "unknown value 'cv_b'"), "control-variate values are not outputs")
    check(lobe.lookup_arrays(pt, []) == {}, "no values asked, none given")
    check(raises(lambda: lobe.lookup({**pt, "theta_h": 1.6}), "theta_h = 1.6 is outside"), "theta_h beyond pi/2 is refused")
    check(raises(lambda: lobe.lookup({**pt, "p": math.nan}), "p = nan is outside"), "NaN is refused")
    check(raises(lambda: lobe.lookup({**pt, "u": [1.0]}), "one number per coordinate"), "lookup takes numbers")
    check(raises(lambda: lobe.lookup({k: v for k, v in pt.items() if k != "c"}), "missing coordinate 'c'"), "a missing coordinate is refused")
    g1 = Table.open(root / "scene-merl_nickel" / "epd_g1.h5")
    check(g1.lookup({"p": 0.9, "a": math.inf})["g1"] == float(g1.lookup_arrays({"p": [0.9], "a": [math.inf]})["g1"][0]), "a = inf")

    # The manifest checks, on lobe's manifest edited in memory.
    m = lobe.manifest
    check_manifest(m, "zh_lobe")
    check_value_encodings(m)
    old = copy.deepcopy(m)
    old["value_encoding"][0] = {"value": "c_lobe", "kind": "ln_control_variates_epd", "formula": "f"}
    check(raises(lambda: check_manifest(old, "zh_lobe"), "before twoscale 0.9.0: rebuild the table"), "an old value encoding is refused")
    swapped = copy.deepcopy(m)
    cvs = swapped["value_encoding"][0]["control_variates"]
    cvs[0], cvs[1] = cvs[1], cvs[0]
    check(raises(lambda: check_value_encodings(swapped), "must be the terms ln_m_s, b, epd_core, tail"), "terms out of order are refused")
    own = copy.deepcopy(m)
    own["value_encoding"][0]["control_variates"][2]["values"] = "c_lobe"
    check(raises(lambda: check_value_encodings(own), "is not a stored value of its own"), "a control variate must be a value of its own")
    underived = copy.deepcopy(m)
    underived["derived_axes"] = []
    check(raises(lambda: check_value_encodings(underived), "control variates need the coordinates"), "control variates need theta_h derived")
    unstored = copy.deepcopy(m)
    unstored["value_encoding"][0]["value"] = "nothing"
    check(raises(lambda: check_value_encodings(unstored), "not a stored value"), "an encoded value must be stored")

    print(f"python reader: {len(FAILURES)} failures")
    for f in FAILURES:
        print("FAIL  " + f)
    return 1 if FAILURES else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip().splitlines()[3].strip())
    sys.exit(main(sys.argv))
