"""The package's checks and API: cubic interpolation on a table built in memory (`test_cubic`);
on a build root (pipeline/tables/golden/make.sh builds one; the `build_root` fixture), outputs
without control-variate values, lookup as lookup_arrays on 0-d arrays, broadcasting, domain
errors, and the manifest checks of the contract (old value encodings, the control variates' layout).

    pytest pipeline/tables/python/tests [--build-root BUILD_ROOT]

Run by tests/suite/read/golden.rs with the shared test tables.
"""
import copy
import math

import numpy as np
from twoscale_tables import Table, encode
from twoscale_tables._manifest import FORMAT, check_contract, check_manifest, check_value_encodings, contract


def raises(f, needle):
    try:
        f()
    except ValueError as e:
        return needle in str(e)
    return False


def cubic_table(interpolation="cubic", sizes=(6, 5, 7)):
    """A table in memory: axes x (`log`, [0.1, 10]), y (`reciprocal`, [0.5, 4]: e decreasing) and z
    (`linear`, [-1, 2]), uniform in their encodings, and the value v = P(e_x, e_y, e_z) (float32),
    P a polynomial of degree 3 in each encoded coordinate. Returns the table and P."""
    specs = [("x", "log", 0.1, 10.0, np.exp), ("y", "reciprocal", 0.5, 4.0, lambda e: 1.0 / e), ("z", "linear", -1.0, 2.0, lambda e: e)]
    rng = np.random.default_rng(7)
    coef = rng.uniform(-1.0, 1.0, (4, 4, 4)) / 64  # of (e_x/2.3)^a (e_y/2)^b (e_z/2)^c: |sum| <= 1

    def poly(ex, ey, ez):
        px, py, pz = [np.power.outer(np.asarray(e, dtype=np.float64) / scale, np.arange(4)) for e, scale in ((ex, 2.3), (ey, 2.0), (ez, 2.0))]
        return 5.0 + np.einsum("...a,...b,...c,abc->...", px, py, pz, coef)

    axes, entries = [], []
    for (name, kind, lo, hi, decode), n in zip(specs, sizes):
        enc = {"kind": kind}
        e0, e1 = encode(enc, lo), encode(enc, hi)
        nodes = decode(e0 + (e1 - e0) * np.arange(n) / (n - 1))
        nodes[0], nodes[-1] = lo, hi
        axes.append(nodes)
        entries.append({"name": name, "size": n, "min": lo, "max": hi, "encoding": enc, "uniform": True, "sha256": "0" * 64})
    grid = np.meshgrid(*[encode(a["encoding"], nodes) for a, nodes in zip(entries, axes)], indexing="ij")
    values = {"v": poly(*grid).astype(np.float32)}
    manifest = {
        "format": FORMAT, "table": "cubic_test", "preset": "test",
        "file": {"path": "cubic_test.h5", "bytes": 0, "sha256": "0" * 64},
        "axes": entries, "values": [{"name": "v", "dtype": "float32", "shape": list(values["v"].shape), "sha256": "0" * 64}],
    }
    if interpolation is not None:
        manifest["interpolation"] = interpolation
    return Table(manifest, axes, values), poly


def test_cubic():
    """Interpolation "cubic": nodes reproduced exactly, a polynomial of degree 3 per encoded coordinate
    to f32 rounding (1e-6 relative) inside and in the edge cells, the domain as for multilinear, the
    manifest's and the file contract's checks; a multilinear table unchanged."""
    table, poly = cubic_table()
    check_manifest(table.manifest, "cubic_test")
    check_value_encodings(table.manifest)
    assert table.cubic and not cubic_table(None)[0].cubic and not cubic_table("multilinear")[0].cubic, "the manifest's interpolation is read"
    mesh = np.meshgrid(*table.axes, indexing="ij")
    at_nodes = table.lookup_arrays(dict(zip("xyz", mesh)))["v"]
    assert np.array_equal(at_nodes, table.values["v"].astype(np.float64)), "cubic: every node is reproduced exactly"

    def err(points):
        got = table.lookup_arrays(dict(zip("xyz", points)))["v"]
        exact = poly(*[encode(a["encoding"], x) for a, x in zip(table.manifest["axes"], points)])
        return np.max(np.abs(got / exact - 1.0))

    rng = np.random.default_rng(1)
    enc = [encode(a["encoding"], nodes) for a, nodes in zip(table.manifest["axes"], table.axes)]
    decode = [np.exp, lambda e: 1.0 / e, lambda e: e]
    uniform = [f(rng.uniform(min(e[0], e[-1]), max(e[0], e[-1]), 20000)) for e, f in zip(enc, decode)]
    assert err(uniform) < 1e-6, f"cubic: a cubic polynomial is reproduced at random points ({err(uniform):.1e})"
    # Every axis in its first or last cell (each of the 8 combinations, 500 points each).
    edges = [[], [], []]
    for corner in range(8):
        for d, (e, f) in enumerate(zip(enc, decode)):
            cell = 0 if (corner >> d) & 1 == 0 else len(e) - 2
            edges[d].append(f(e[cell] + rng.uniform(0.0, 1.0, 500) * (e[cell + 1] - e[cell])))
    edges = [np.concatenate(x) for x in edges]
    assert err(edges) < 1e-6, f"cubic: ... and in the edge cells ({err(edges):.1e})"
    # The smallest cubic table: 4 nodes per axis (one stencil for every cell).
    small, poly4 = cubic_table(sizes=(4, 4, 4))
    pts = [x[:2000] for x in uniform]
    got = small.lookup_arrays(dict(zip("xyz", pts)))["v"]
    assert np.max(np.abs(got / poly4(*[encode(a["encoding"], x) for a, x in zip(small.manifest["axes"], pts)]) - 1.0)) < 1e-6, (
        "cubic: 4 nodes per axis"
    )
    # The same data multilinear: nodes still exact, the polynomial no longer reproduced, "multilinear" = absent.
    linear, _ = cubic_table(None)
    point = dict(zip("xyz", uniform))
    assert np.array_equal(linear.lookup_arrays(dict(zip("xyz", mesh)))["v"], table.values["v"].astype(np.float64)), "multilinear: nodes exact"
    assert np.max(np.abs(linear.lookup_arrays(point)["v"] - table.lookup_arrays(point)["v"])) > 1e-3, "multilinear differs from cubic between nodes"
    assert np.array_equal(linear.lookup_arrays(point)["v"], cubic_table("multilinear")[0].lookup_arrays(point)["v"]), "\"multilinear\" is the default"
    one = table.lookup({"x": 0.3, "y": 1.1, "z": 0.4})["v"]
    assert one == float(table.lookup_arrays({"x": [0.3, 0.3], "y": 1.1, "z": 0.4})["v"][1]), "cubic: lookup is lookup_arrays"
    # The domain, as for multilinear.
    inside = {"x": 1.0, "y": 1.0, "z": 0.0}
    for name, x in (("x", 0.099), ("x", 10.01), ("y", 0.49), ("y", 4.5), ("z", -1.01), ("z", 2.01), ("z", math.nan)):
        assert raises(lambda: table.lookup({**inside, name: x}), f"{name} = {x} is outside"), f"cubic: {name} = {x} is refused"
    # The manifest's checks.
    m = table.manifest
    for what, edit, needle in (
        ("an unknown interpolation", lambda m: m.update(interpolation="bicubic"), "unknown interpolation 'bicubic'"),
        ("a non-string interpolation", lambda m: m.update(interpolation=["cubic"]), "unknown interpolation"),
        ("a non-uniform axis", lambda m: m["axes"][1].update(uniform=False), "uniform in its encoding, and axis y is not"),
        ("an axis of 3 nodes", lambda m: m["axes"][2].update(size=3), "at least 4 nodes per axis, and axis z has 3"),
        ("derived axes", lambda m: m.update(derived_axes=[{"kind": "material_lobe_angle", "axis": "z", "coordinate": "theta", "inputs": ["u"]}]),
         "no derived axes"),
        ("value encodings", lambda m: m.update(value_encoding=[{"value": "v", "kind": "ln"}]), "no value encodings"),
    ):
        bad = copy.deepcopy(m)
        edit(bad)
        assert raises(lambda: check_manifest(bad, "cubic_test"), needle), f"cubic: {what} is refused"
    assert raises(lambda: Table(dict(m, interpolation="spline"), table.axes, table.values), "unknown interpolation 'spline'"), (
        "Table refuses an unknown interpolation"
    )
    # The file's attribute `contract` against the manifest: "interpolation" absent or "multilinear" is multilinear.
    lin = linear.manifest
    assert "interpolation" not in contract(lin) and contract(m)["interpolation"] == "cubic", "the contract records cubic only"
    check_contract(contract(m), m)
    check_contract(contract(lin), lin)
    check_contract(dict(contract(lin), interpolation="multilinear"), lin)
    check_contract(contract(lin), dict(lin, interpolation="multilinear"))
    for recorded, manifest, what in ((contract(lin), m, "a multilinear file, a cubic manifest"), (contract(m), lin, "a cubic file, a multilinear manifest"),
                                     (dict(contract(m), interpolation="bicubic"), m, "an unknown interpolation in the file")):
        assert raises(lambda: check_contract(recorded, manifest), "the interpolation ("), f"refused: {what}"
    assert raises(lambda: check_contract(dict(contract(m), values=["w"]), m), "the contract (axis order"), "refused: another contract"


def test_build_root_tables(build_root):
    """The package's API and manifest checks on the build root's zh_lobe and epd_g1."""
    root = build_root
    lobe = Table.open(root / "scene-broad_lobe" / "zh_lobe.h5")
    assert lobe.outputs() == ["c_lobe"] and set(lobe.values) == {"c_lobe", "cv_ln_m_s", "cv_b", "cv_epd_core", "cv_tail"}, (
        "zh_lobe's outputs are c_lobe alone"
    )
    pt = {"u": 6.0, "c": 1.95, "p": 0.41, "beta": 0.24, "theta_h": 0.9}
    one = lobe.lookup(pt)
    assert isinstance(one["c_lobe"], float), "lookup returns floats"
    grid = lobe.lookup_arrays({**pt, "theta_h": np.array([[0.0, 0.9], [1.2, math.pi / 2]])})
    assert grid["c_lobe"].shape == (2, 2) and grid["c_lobe"][0, 1] == one["c_lobe"], "lookup_arrays broadcasts and equals lookup"
    zero_d = lobe.lookup_arrays({k: np.float64(v) for k, v in pt.items()})
    assert zero_d["c_lobe"].shape == () and float(zero_d["c_lobe"]) == one["c_lobe"], "0-d arrays give 0-d arrays"
    assert lobe.lookup_arrays({**pt, "u": np.zeros(0)})["c_lobe"].shape == (0,), "no points, no values"
    assert raises(lambda: lobe.lookup_arrays(pt, ["cv_b"]), "unknown value 'cv_b'"), "control-variate values are not outputs"
    assert lobe.lookup_arrays(pt, []) == {}, "no values asked, none given"
    assert raises(lambda: lobe.lookup({**pt, "theta_h": 1.6}), "theta_h = 1.6 is outside"), "theta_h beyond pi/2 is refused"
    assert raises(lambda: lobe.lookup({**pt, "p": math.nan}), "p = nan is outside"), "NaN is refused"
    assert raises(lambda: lobe.lookup({**pt, "u": [1.0]}), "one number per coordinate"), "lookup takes numbers"
    assert raises(lambda: lobe.lookup({k: v for k, v in pt.items() if k != "c"}), "missing coordinate 'c'"), "a missing coordinate is refused"
    g1 = Table.open(root / "scene-merl_nickel" / "epd_g1.h5")
    assert g1.lookup({"p": 0.9, "a": math.inf})["g1"] == float(g1.lookup_arrays({"p": [0.9], "a": [math.inf]})["g1"][0]), "a = inf"

    # The manifest checks, on lobe's manifest edited in memory.
    m = lobe.manifest
    check_manifest(m, "zh_lobe")
    check_value_encodings(m)
    old = copy.deepcopy(m)
    old["value_encoding"][0] = {"value": "c_lobe", "kind": "ln_control_variates_epd", "formula": "f"}
    assert raises(lambda: check_manifest(old, "zh_lobe"), "before twoscale 0.9.0: rebuild the table"), "an old value encoding is refused"
    swapped = copy.deepcopy(m)
    cvs = swapped["value_encoding"][0]["control_variates"]
    cvs[0], cvs[1] = cvs[1], cvs[0]
    assert raises(lambda: check_value_encodings(swapped), "must be the terms ln_m_s, b, epd_core, tail"), "terms out of order are refused"
    own = copy.deepcopy(m)
    own["value_encoding"][0]["control_variates"][2]["values"] = "c_lobe"
    assert raises(lambda: check_value_encodings(own), "is not a stored value of its own"), "a control variate must be a value of its own"
    underived = copy.deepcopy(m)
    underived["derived_axes"] = []
    assert raises(lambda: check_value_encodings(underived), "control variates need the coordinates"), "control variates need theta_h derived"
    unstored = copy.deepcopy(m)
    unstored["value_encoding"][0]["value"] = "nothing"
    assert raises(lambda: check_value_encodings(unstored), "not a stored value"), "an encoded value must be stored"
