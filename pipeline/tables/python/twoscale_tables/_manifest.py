"""What a reader checks of a manifest before and after it opens the table file (docs/file_contract.md,
"Opening a table"); mirrors pipeline/tables/src/file.rs."""
import hashlib
import stat
from pathlib import Path

import numpy as np

from ._axes import LOBE_ANGLES
from ._lobe import COORDINATES as LOBE_COORDINATES
from ._lobe import TERMS

FORMAT = "twoscale-manifest/1"
TABLE_FORMAT = "twoscale-table/1"
INTERPOLATIONS = ("multilinear", "cubic")  # manifest `interpolation`; absent is multilinear


def _need(cond, what):
    if not cond:
        raise ValueError(what)


def _is_str(x):
    return isinstance(x, str)


def check_manifest(m, table):
    """The fields a lookup reads, with their types (ValueError naming the first that is wrong)."""
    _need(isinstance(m, dict), "not a JSON object")
    _need(m.get("format") == FORMAT, f"format {m.get('format')!r}, not {FORMAT!r}")
    _need(m.get("table") == table, f"it is for table {m.get('table')!r}, not {table!r}")
    _need(_is_str(m.get("preset")), "bad `preset`")
    f = m.get("file")
    _need(isinstance(f, dict) and _is_str(f.get("path")) and type(f.get("bytes")) is int and _is_str(f.get("sha256")), "bad `file` entry")
    _need(f["path"] == f"{table}.h5", f"file.path is {f['path']!r}, not {table + '.h5'!r}")
    for key, fields in (("axes", ("name", "sha256")), ("values", ("name", "sha256", "dtype"))):
        _need(isinstance(m.get(key), list) and m[key], f"`{key}` is not a non-empty list")
        for e in m[key]:
            _need(isinstance(e, dict) and all(_is_str(e.get(k)) for k in fields), f"bad entry in `{key}`")
    for a in m["axes"]:
        _need(isinstance(a.get("encoding"), dict) and _is_str(a["encoding"].get("kind")), f"axis {a['name']}: bad encoding")
        _need(type(a.get("size")) is int and all(isinstance(a.get(k), (int, float, str)) for k in ("min", "max")), f"axis {a['name']}: bad size or range")
    for v in m["values"]:
        _need(isinstance(v.get("shape"), list), f"value {v['name']}: bad shape")
    for key in ("derived_axes", "value_encoding"):
        _need(isinstance(m.get(key, []), list) and all(isinstance(e, dict) for e in m.get(key, [])), f"bad `{key}`")
    for d in m.get("derived_axes", []):
        _need(d.get("kind") in LOBE_ANGLES, f"unknown derived axis {d.get('kind')!r}")
        _need(_is_str(d.get("axis")) and _is_str(d.get("coordinate")) and isinstance(d.get("inputs"), list), "bad entry in `derived_axes`")
        _need(d["inputs"] == LOBE_ANGLES[d["kind"]], f"derived axis {d['kind']} takes the inputs {LOBE_ANGLES[d['kind']]}, not {d['inputs']}")
    for e in m.get("value_encoding", []):
        kind = e.get("kind")
        if _is_str(kind) and kind.startswith("ln_control_variates"):
            # The value encodings of 0.5.0 to 0.8.0 became stored control variates in 0.9.0.
            raise ValueError(f"value encoding {kind!r} is from before twoscale 0.9.0: rebuild the table")
        _need(kind == "ln", f"unknown value encoding {kind!r}")
        cvs = e.get("control_variates", [])
        _need(_is_str(e.get("value")) and isinstance(cvs, list), "bad entry in `value_encoding`")
        _need(all(isinstance(cv, dict) and _is_str(cv.get("term")) and _is_str(cv.get("values")) for cv in cvs), f"bad control variates of {e['value']}")
    check_interpolation(m)


def interpolation(m):
    """The manifest's `interpolation`: "multilinear" (also when absent) or "cubic"."""
    kind = m.get("interpolation", "multilinear")
    _need(_is_str(kind) and kind in INTERPOLATIONS, f"unknown interpolation {kind!r} (multilinear or cubic)")
    return kind


def check_interpolation(m):
    """The interpolation, after checking that a cubic table has what its stencil needs: every axis
    uniform in its encoding with at least 4 nodes, no derived axes and no value encodings."""
    kind = interpolation(m)
    if kind == "cubic":
        for a in m["axes"]:
            _need(a.get("uniform") is True, f"a cubic table needs every axis uniform in its encoding, and axis {a['name']} is not")
            _need(a["size"] >= 4, f"a cubic table needs at least 4 nodes per axis, and axis {a['name']} has {a['size']}")
        _need(not m.get("derived_axes") and not m.get("value_encoding"), "a cubic table has no derived axes and no value encodings")
    return kind


def check_value_encodings(m):
    """Every derived axis reads coordinates of the table; every encoded value names a stored value; control variates are zh_lobe's four terms in the
    order of TERMS, each in a stored value of its own, on the coordinates u, c, p, beta and
    theta_h, the last one derived (zh_lobe's layout): the lookup relies on it."""
    derived = {d["axis"]: d["coordinate"] for d in m.get("derived_axes", [])}
    names = [derived.get(a["name"], a["name"]) for a in m["axes"]]
    for d in m.get("derived_axes", []):
        missing = [n for n in d["inputs"] if n not in names]
        _need(not missing, f"derived axis {d['axis']} reads {missing[0] if missing else ''!r}, which is not a coordinate of the table ({', '.join(names)})")
    stored = {v["name"] for v in m["values"]}
    for e in m.get("value_encoding", []):
        _need(e["value"] in stored, f"value_encoding names {e['value']!r}, which is not a stored value")
        cvs = e.get("control_variates", [])
        if not cvs:
            continue
        terms = [cv["term"] for cv in cvs]
        _need(terms == list(TERMS), f"the control variates of {e['value']} must be the terms {', '.join(TERMS)} in that order, not {', '.join(terms)}")
        for cv in cvs:
            _need(cv["values"] != e["value"] and cv["values"] in stored, f"control variate {cv['values']!r} of {e['value']} is not a stored value of its own")
        last_derived = len(derived) == 1 and len(names) == len(LOBE_COORDINATES) and m["axes"][4]["name"] in derived
        _need(names == LOBE_COORDINATES and last_derived,
              f"control variates need the coordinates {', '.join(LOBE_COORDINATES)} (theta_h derived), not {', '.join(names)}")


def contract(m):
    """What the file's attribute `contract` records of the manifest: axes in order with their
    encodings, value names, derived axes, value encodings, and `"interpolation": "cubic"` for a
    cubic table (absent for a multilinear one)."""
    c = {
        "axes": [{"name": a["name"], "encoding": a["encoding"]} for a in m["axes"]],
        "values": [v["name"] for v in m["values"]],
        "derived_axes": m.get("derived_axes", []),
        "value_encoding": m.get("value_encoding", []),
    }
    if interpolation(m) == "cubic":
        c["interpolation"] = "cubic"
    return c


def check_contract(recorded, m):
    """The file's attribute `contract` (parsed) against the manifest: ValueError naming what differs.
    An interpolation absent or "multilinear" is multilinear, in the file as in the manifest."""
    mine = contract(m)
    theirs = dict(recorded) if isinstance(recorded, dict) else {}
    kinds = theirs.pop("interpolation", "multilinear"), mine.pop("interpolation", "multilinear")
    _need(kinds[0] == kinds[1], f"the interpolation ({kinds[1]}; the file's contract: {kinds[0]!r})")
    _need(isinstance(recorded, dict) and theirs == mine, "the contract (axis order and encodings, derived axes, value encodings)")


def json_f64(x):
    """A manifest number (+inf is the string "inf")."""
    if isinstance(x, str):
        if x not in ("inf", "-inf"):
            raise ValueError(f"{x!r} is not a number")
        return float(x)
    return float(x)


def sha256(array, dtype):
    """SHA-256 of an array's canonical bytes: little-endian, C order."""
    return hashlib.sha256(np.ascontiguousarray(array, dtype=dtype).tobytes()).hexdigest()


def verify_file(path, manifest):
    """Checks the table file `path` against the manifest's `file` entry: its name, size, then
    SHA-256 (before any HDF5 library sees it: it can crash or hang on a malformed file)."""
    path, entry = Path(path), manifest["file"]
    if entry["path"] != path.name:
        raise ValueError(f"{path}: the manifest describes {entry['path']!r}")
    try:
        st = path.stat()
    except OSError as e:
        raise ValueError(f"cannot read {path}: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{path} is not a file")
    size = st.st_size
    if size != entry["bytes"]:
        raise ValueError(f"{path} has {size} bytes, the manifest says {entry['bytes']}")
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    if h.hexdigest() != entry["sha256"]:
        raise ValueError(f"{path}: file checksum differs from the manifest")
