"""The package reproduces the golden vectors (pipeline/tables/golden/vectors.json): every value
within the file's tolerance (1e-12 relative, or 1e-300 absolute), the same value names as the CLI,
and `lookup_arrays` over each table's points equal to `lookup` at each (one code path).

    pytest pipeline/tables/python/tests --build-root BUILD_ROOT [--vectors VECTORS]

BUILD_ROOT holds the tables the vectors were made from (pipeline/tables/golden/make.sh builds
them). Run by tests/suite/read/golden.rs; prints the count and the largest difference (-rP).
"""
import json
import math
from pathlib import Path

import numpy as np
from twoscale_tables import Table


def physical(x):
    """A point's coordinate: a number, or the string "inf"."""
    return math.inf if x == "inf" else float(x)


def compare(root, vectors_path):
    """(vectors, tables, largest relative difference, failures) of the package against the vectors."""
    golden = json.loads(Path(vectors_path).read_text())
    assert golden["format"] == "twoscale-golden/1", golden["format"]
    rel, absolute = golden["tolerance"]["relative"], golden["tolerance"]["absolute"]
    failures, worst, tables = [], 0.0, {}
    by_table = {}
    for k, v in enumerate(golden["vectors"]):
        key = (v["tables"], v["table"])
        if key not in tables:
            tables[key] = Table.open(Path(root) / v["tables"] / f"{v['table']}.h5")
        point = {n: physical(x) for n, x in v["point"].items()}
        got = tables[key].lookup(point)
        by_table.setdefault(key, []).append((point, got))
        if sorted(got) != sorted(v["values"]):
            failures.append(f"vector {k} ({'/'.join(key)} at {v['point']}): values {sorted(got)}, expected {sorted(v['values'])}")
            continue
        for name, want in v["values"].items():
            err = abs(got[name] - want)
            if not err <= max(rel * abs(want), absolute):
                failures.append(f"vector {k} ({'/'.join(key)} at {v['point']}): {name} = {got[name]!r}, expected {want!r}")
            elif want != 0.0:
                worst = max(worst, err / abs(want))
    for key, rows in by_table.items():
        arrays = tables[key].lookup_arrays({n: np.array([p[n] for p, _ in rows]) for n in rows[0][0]})
        for i, (_, got) in enumerate(rows):
            if any(arrays[n][i] != got[n] for n in got):
                failures.append(f"{'/'.join(key)}: lookup_arrays differs from lookup at point {i}")
    return len(golden["vectors"]), len(tables), worst, failures


def test_golden_vectors(build_root, vectors):
    n, ntables, worst, failures = compare(build_root, vectors)
    print(f"python golden: {n} vectors over {ntables} tables, {len(failures)} failures, largest relative difference {worst:.1e}")
    assert not failures, "\n".join(failures)
