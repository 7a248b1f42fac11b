"""Mitsuba 3's `measured` plugin (Dupuy and Jakob 2018's RGL-EPFL files, *_rgb.bsdf) evaluated at given direction
pairs: the reference tests/suite/fit/rgl.rs holds twoscale's reader (pipeline/fit/src/rgl.rs) to.

    .venv/bin/python -m mitsuba_measured IN.json OUT.json

IN.json: {"cases": [{"file": PATH, "pairs": [[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z], ...]}, ...]}, unit vectors in the
local frame (z the normal). wi is Mitsuba's si.wi (the file's incident direction, whose elevation selects the file's
slices), wo the direction BSDF::eval takes. OUT.json: {"values": [[[r, g, b], ...], ...]}, BSDF::eval per case and
pair: f times cos theta of wo (the plugin returns the stored value times its Jacobian factor, which is that), in the
scalar_rgb variant (float32). A bad input is one line on stderr and exit status 2.
"""
import argparse
import json
import sys
from pathlib import Path


def evaluate(cases):
    """BSDF::eval of each case's file at each of its pairs, [[r, g, b], ...] per case."""
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Warn)
    ctx = mi.BSDFContext()
    out = []
    for case in cases:
        bsdf = mi.load_dict({"type": "measured", "filename": str(case["file"])})
        si = mi.SurfaceInteraction3f()
        values = []
        for p in case["pairs"]:
            si.wi = mi.Vector3f(p[0], p[1], p[2])
            v = bsdf.eval(ctx, si, mi.Vector3f(p[3], p[4], p[5]))
            values.append([float(v[0]), float(v[1]), float(v[2])])
        out.append(values)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="mitsuba_measured", description="Mitsuba 3's `measured` BSDF::eval of RGL files at direction pairs.")
    ap.add_argument("input", type=Path, help='JSON: {"cases": [{"file": PATH, "pairs": [[wi, wo as six numbers], ...]}, ...]}')
    ap.add_argument("output", type=Path, help='JSON written: {"values": [[[r, g, b] per pair] per case]}')
    args = ap.parse_args(argv)
    try:
        cases = json.loads(args.input.read_text())["cases"]
        for case in cases:
            if not Path(case["file"]).is_file():
                raise ValueError(f"{case['file']}: no such file")
            if any(len(p) != 6 for p in case["pairs"]):
                raise ValueError(f"{case['file']}: a pair is six numbers, wi then wo")
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"mitsuba_measured: error: {e}", file=sys.stderr)
        sys.exit(2)
    args.output.write_text(json.dumps({"values": evaluate(cases)}))


if __name__ == "__main__":
    main()
