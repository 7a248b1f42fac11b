"""Read twoscale tables without twoscale: verify a table file and its data checksums against the
manifest beside it, and interpolate and decode exactly as `twoscale lookup` does (multilinear, or
tensor-product cubic where the manifest says so, in the encoded coordinates of each axis;
docs/file_contract.md).

    from twoscale_tables import Table
    t = Table.open("tables-out/default/epd_g1.h5")
    t.lookup({"p": 1.5, "a": 0.7})                  # {"g1": ...}
    t.lookup_arrays({"p": ps, "a": as_})            # the same over numpy arrays (broadcast together)

`lookup` is `lookup_arrays` on 0-d arrays: one code path, the same numbers bit for bit.
From the shell: `python -m twoscale_tables lookup FILE.h5 NAME=VALUE ...`. Bundles, signed or not:
`twoscale_tables.bundle` (`unpacked`, `status`).
"""
import json
from pathlib import Path

import h5py
import numpy as np

from . import _lobe, bundle
from ._axes import derive, encode
from ._manifest import TABLE_FORMAT, check_contract, check_interpolation, check_manifest, check_value_encodings, json_f64, sha256, verify_file

__version__ = "0.10.0"
CHUNK = 1024  # points interpolated at a time (fewer when a point reads more than 64 nodes)
__all__ = ["Table", "bundle", "derive", "encode", "open_folder", "sha256", "verify_file"]


def open_folder(folder, names, build_hint):
    """{name: Table} of FOLDER/NAME.h5 for each name, every checksum verified; ValueError naming the file: a
    missing table (with build_hint, what builds it), a mismatch (Table.open's message) or an unreadable one."""
    tables = {}
    for name in names:
        h5 = Path(folder) / f"{name}.h5"
        if not h5.exists():
            raise ValueError(f"{folder}: table {name} is missing ({build_hint})")
        try:
            tables[name] = Table.open(h5)
        except (OSError, KeyError) as e:
            raise ValueError(f"{h5}: unreadable table ({e})") from None
    return tables


class Table:
    """One table: `manifest` (the parsed manifest), `axes` (node arrays, in the manifest's order),
    `values` ({name: float32 array} of every stored value)."""

    def __init__(self, manifest, axes, values):
        self.manifest, self.axes, self.values = manifest, axes, values
        self.encoded = [encode(a["encoding"], nodes) for a, nodes in zip(manifest["axes"], axes)]
        # Encoded values (all `ln`) and the stored values holding their control variates, in term order.
        self._control = {e["value"]: [cv["values"] for cv in e.get("control_variates", [])] for e in manifest.get("value_encoding", [])}
        held = {name for cvs in self._control.values() for name in cvs}
        self._outputs = [v["name"] for v in manifest["values"] if v["name"] not in held]
        self._derived = {d["axis"]: d for d in manifest.get("derived_axes", [])}
        self.cubic = check_interpolation(manifest) == "cubic"

    @classmethod
    def open(cls, path):
        """Reads FILE.h5 and FILE.manifest.json beside it; ValueError on anything wrong. The file's
        size and SHA-256 are checked against the manifest before h5py opens it (the HDF5 library can
        crash or hang on a malformed file), then the file's own record of the manifest (attribute
        `contract`: axes, values, derived axes, value encodings, interpolation), every data checksum
        and the control variates' layout."""
        path = Path(path)
        if path.suffix != ".h5":
            raise ValueError(f"{path}: a table file ends in .h5")
        table = path.name[: -len(".h5")]
        mpath = path.with_name(table + ".manifest.json")
        try:
            text = mpath.read_text()
        except OSError as e:
            raise ValueError(f"cannot read {mpath}: {e.strerror}") from None
        try:
            manifest = json.loads(text)
            check_manifest(manifest, table)
        except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as e:
            raise ValueError(f"{mpath}: malformed manifest: {e}") from None
        verify_file(path, manifest)
        try:
            with h5py.File(path, "r") as f:
                attrs = {k: f.attrs.get(k) for k in ("format", "table", "preset", "contract")}
                if attrs["format"] != TABLE_FORMAT:
                    raise ValueError(f"format is {attrs['format']!r}, expected {TABLE_FORMAT!r}")
                if attrs["contract"] is None:
                    raise ValueError("no attribute `contract` (written before twoscale 0.8.0): rebuild it")
                file_contract = json.loads(attrs["contract"])
                axes = [np.asarray(f["axes"][a["name"]][()], dtype="<f8") for a in manifest["axes"]]
                values = {v["name"]: np.asarray(f["values"][v["name"]][()], dtype="<f4") for v in manifest["values"]}
        except (OSError, KeyError, TypeError, ValueError) as e:
            raise ValueError(f"{path}: not a readable twoscale table: {e}") from None
        if (attrs["table"], attrs["preset"]) != (manifest["table"], manifest["preset"]):
            raise ValueError(f"{mpath}: the table or preset differs from the file {path}")
        try:
            check_contract(file_contract, manifest)
        except ValueError as e:
            raise ValueError(f"{mpath}: {e} differs from the file {path}") from None
        cubic = check_interpolation(manifest) == "cubic"
        for a, nodes in zip(manifest["axes"], axes):
            if sha256(nodes, "<f8") != a["sha256"]:
                raise ValueError(f"{path}: axis {a['name']} does not match its manifest checksum")
            if nodes.ndim != 1 or a["size"] != len(nodes) or len(nodes) < 2 or json_f64(a["min"]) != nodes.min() or json_f64(a["max"]) != nodes.max():
                raise ValueError(f"{mpath}: axis {a['name']}'s entry (size, range) differs from the file {path}")
            e = encode(a["encoding"], nodes)
            step = np.diff(e) * np.sign(e[1] - e[0])
            if not (np.all(np.isfinite(e)) and np.all(step > 0)):
                raise ValueError(f"{path}: axis {a['name']}: the encoded nodes are not finite and strictly monotone")
            # A cubic stencil's weights hold for nodes equally spaced in e (to 1e-9 of the span, as axis.rs `is_uniform`).
            if cubic and not np.all(np.abs(e - (e[0] + (e[-1] - e[0]) * np.arange(len(e)) / (len(e) - 1))) <= 1e-9 * abs(e[-1] - e[0])):
                raise ValueError(f"{path}: axis {a['name']} of a cubic table is not uniform in its encoding")
        for v in manifest["values"]:
            data = values[v["name"]]
            if sha256(data, "<f4") != v["sha256"]:
                raise ValueError(f"{path}: values/{v['name']} does not match its manifest checksum")
            if v["dtype"] != "float32" or list(data.shape) != v["shape"] or data.shape != tuple(len(x) for x in axes):
                raise ValueError(f"{mpath}: values/{v['name']}'s entry (dtype, shape) differs from the file {path}")
        try:
            check_value_encodings(manifest)
        except ValueError as e:
            raise ValueError(f"{mpath}: malformed manifest: {e}") from None
        return cls(manifest, axes, values)

    def coordinates(self):
        """The physical coordinates a lookup takes, in order: each axis, or the coordinate a derived
        axis comes from."""
        return [self._derived[a["name"]]["coordinate"] if a["name"] in self._derived else a["name"] for a in self.manifest["axes"]]

    def outputs(self):
        """The values a lookup returns, in order: every stored value but those holding control variates."""
        return list(self._outputs)

    def lookup(self, point):
        """{value name: float} at one point {coordinate name: number} (`lookup_arrays` on 0-d arrays)."""
        if any(np.ndim(x) for x in point.values()):
            raise ValueError("lookup takes one number per coordinate (lookup_arrays takes arrays)")
        return {name: float(v) for name, v in self.lookup_arrays(point).items()}

    def lookup_arrays(self, point, values=None):
        """{value name: ndarray} at the points {coordinate name: array-like} (broadcast together), for
        the named values (default: every output): derived axes computed from the physical
        coordinates, every stored value interpolated with the same cell weights, then decoded
        (exp of the interpolated ln, plus zh_lobe's control variates at the points)."""
        names = self._check_coordinates(point)
        wanted = self._outputs if values is None else list(values)
        for name in wanted:
            if name not in self._outputs:
                raise ValueError(f"unknown value {name!r} (values: {', '.join(self._outputs)})")
        arrays = [np.asarray(point[n], dtype=np.float64) for n in names]
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
        physical = [np.ascontiguousarray(np.broadcast_to(a, shape)).reshape(-1) for a in arrays]
        stored, cells = self._cells(physical, names)
        needed = list(dict.fromkeys(wanted + [cv for name in wanted for cv in self._control.get(name, [])]))
        sums = self._interpolate(cells, needed) if needed else {}
        out = {}
        for name in wanted:
            x = sums[name]
            if name in self._control:
                cvs = self._control[name]
                if cvs:  # checked by `open`: coordinates u, c, p, beta, theta_h (derived, stored as v)
                    u, c, p, beta, theta = physical
                    x = x + _lobe.correction(theta, u, c, p, beta, stored[4], [sums[cv] for cv in cvs])
                with np.errstate(over="ignore"):
                    x = np.exp(x)
            out[name] = x.reshape(shape)
        return out

    def _check_coordinates(self, point):
        """The coordinate names, after checking that `point` names each exactly once."""
        names = self.coordinates()
        unknown = set(point) - set(names)
        if unknown:
            raise ValueError(f"unknown axis {sorted(unknown)[0]!r} (axes: {', '.join(names)})")
        missing = [n for n in names if n not in point]
        if missing:
            raise ValueError(f"missing coordinate {missing[0]!r}")
        return names

    def _cells(self, physical, names):
        """The stored coordinates of the physical points (1-D arrays in the order of `coordinates`) and
        each axis's (cells, weights of the upper nodes). Physical coordinates outside their axes are
        reported before any derivation, then derived coordinates outside their ranges."""
        axes = self.manifest["axes"]
        cells = [None if a["name"] in self._derived else self._locate(i, physical[i]) for i, a in enumerate(axes)]
        stored = list(physical)
        for i, a in enumerate(axes):
            d = self._derived.get(a["name"])
            if d is None:
                continue
            x = physical[i]
            bad = np.isnan(x) | (x < d["min"]) | (x > d["max"])
            if bad.any():
                raise ValueError(f"{d['coordinate']} = {x[np.argmax(bad)]} is outside the table's domain [{d['min']}, {d['max']}]")
            stored[i] = derive(d, x, [physical[names.index(n)] for n in d["inputs"]])
            cells[i] = self._locate(i, stored[i])
        return stored, cells

    def _locate(self, i, x):
        """The cells of axis i holding the coordinates x and the weights t of their upper nodes:
        e(x_cell) <= e(x) <= e(x_cell+1) in the encoding (reversed on a decreasing axis)."""
        name, enc = self.manifest["axes"][i]["name"], self.encoded[i]
        e = encode(self.manifest["axes"][i]["encoding"], x)
        sign = 1.0 if enc[-1] > enc[0] else -1.0
        with np.errstate(invalid="ignore"):
            bad = np.isnan(x) | np.isnan(e) | (sign * e < sign * enc[0]) | (sign * e > sign * enc[-1])
        if bad.any():
            raise ValueError(f"{name} = {x[np.argmax(bad)]} is outside the table's domain [{self.axes[i].min()}, {self.axes[i].max()}]")
        upper = np.minimum(np.maximum(np.searchsorted(sign * enc, sign * e, side="right"), 1), len(enc) - 1)
        cell = upper - 1
        t = (e - enc[cell]) / (enc[cell + 1] - enc[cell])
        return cell, np.minimum(np.maximum(t, 0.0), 1.0)

    def _interpolate(self, cells, names):
        """{name: the interpolation of values[name]} over the cells: the weighted sum of the nodes
        that `_linear_weights` or `_cubic_weights` give, in their order, in the order of the Rust
        reader (interp.rs: weights multiplied in axis order, nodes of weight 0 left out, the sum taken
        node after node). Points go CHUNK at a time (temporaries that stay in cache)."""
        shape = self.values[names[0]].shape
        dims = len(cells)
        strides = np.array([int(np.prod(shape[d + 1 :], dtype=np.int64)) for d in range(dims)], dtype=np.intp)
        if self.cubic:  # node k: digit a_d = (k >> 2 (dims-1-d)) & 3 of axis d, C order
            steps = (np.arange(4**dims)[:, None] >> (2 * np.arange(dims - 1, -1, -1))) & 3
        else:  # corner k: bit d = (k >> d) & 1 of axis d
            steps = (np.arange(1 << dims)[:, None] >> np.arange(dims)) & 1
        offsets = (steps * strides).sum(axis=1)[:, None]  # (nodes, 1)
        chunk = max(1, min(CHUNK, 64 * CHUNK // len(offsets)))
        weigh = self._cubic_weights if self.cubic else self._linear_weights
        flat = {n: self.values[n].reshape(-1) for n in names}
        count = len(cells[0][0])
        sums = {n: np.empty(count) for n in names}
        for lo in range(0, count, chunk):
            weights, base = weigh([(cell[lo : lo + chunk], t[lo : lo + chunk]) for cell, t in cells], shape, strides)
            w = np.array(weights)  # (nodes, points)
            index, keep = base + offsets, w != 0.0
            for n in names:
                terms = np.where(keep, w * flat[n][index].astype(np.float64), 0.0)
                total = terms[0].copy()
                for node in terms[1:]:  # one node after the other
                    total += node
                sums[n][lo : lo + chunk] = total
        return sums

    @staticmethod
    def _linear_weights(cells, shape, strides):
        """Multilinear: the 2^N corners of the cells (corner bit d the upper node along axis d) and
        the offset of their lower corners."""
        weights, base = [1.0], 0
        for d, (cell, t) in enumerate(cells):
            # Axis d's bit doubles the corners: lower node (1 - t) first, then upper (t).
            weights = [w * (1.0 - t) for w in weights] + [w * t for w in weights]
            base = base + cell * strides[d]
        return weights, base

    @staticmethod
    def _cubic_weights(cells, shape, strides):
        """Tensor-product cubic (interpolation "cubic"): on each axis the 4 nodes s..s+3,
        s = min(max(i, 1), n-3) - 1, around cell i, at tau = t + (i - s) - 1 (node spacings from node
        s+1: [0, 1] inside, [-1, 0] in the first cell, [1, 2] in the last), with the Lagrange weights
        through -1, 0, 1, 2
            w0 = -tau (tau-1)(tau-2)/6,  w1 = (tau+1)(tau-1)(tau-2)/2,
            w2 = -(tau+1) tau (tau-2)/2, w3 = (tau+1) tau (tau-1)/6;
        the 4^N nodes in C order (axis 0 slowest) and the offset of node (s_0, s_1, ...)."""
        weights, base = [1.0], 0
        for d, (cell, t) in enumerate(cells):
            s = np.minimum(np.maximum(cell, 1), shape[d] - 3) - 1
            tau = t + (cell - s) - 1.0
            axis = (
                -tau * (tau - 1) * (tau - 2) / 6,
                (tau + 1) * (tau - 1) * (tau - 2) / 2,
                -(tau + 1) * tau * (tau - 2) / 2,
                (tau + 1) * tau * (tau - 1) / 6,
            )
            weights = [w * a for w in weights for a in axis]
            base = base + s * strides[d]
        return weights, base
