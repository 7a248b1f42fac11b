"""The explorer's speed measure: the per-pixel cost of the twoscale sphere pass against a GGX pass drawn by the
same page (index.html?bench=1: the same spectral loop and tone mapping, only the BRDF differs), in headless
Chromium on the wall clock (cdp.py). Prints the page's JSON.

    .venv/bin/python runtimes/webgl/tools/bench.py --dir tables-out/scene-render_materials/nickel [--n 20 --size 256 --lobe fit]
        [--tables tables-out/default [--map beta]]

With --tables, the general export's sphere pass at the material's parameters (with --map, beta or sigma_s per
pixel from the page's map) is timed beside the material's own pass and the GGX pass: ratio_material_net.

Without a GPU Chromium renders with SwiftShader, a CPU rasteriser: the ratio is the result, not the times.
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from browser import Server, export_webgl  # browser, twoscale_c: runtimes/testing (`make pyenv` installs it)
from cdp import Browser  # beside this script
from twoscale_c import twoscale_binary

HERE = Path(__file__).resolve().parents[1]  # the runtime's folder (these tools are in its tools/)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", required=True, type=Path, help="a material folder (built tables)")
    ap.add_argument("--n", type=int, default=20, help="draws of each pass")
    ap.add_argument("--size", type=int, default=256, help="the passes' resolution (size x size)")
    ap.add_argument("--lobe", default="exact", choices=["exact", "fit"])
    ap.add_argument("--energy", default="single", choices=["single", "compensated"])
    ap.add_argument("--tables", type=Path, help="the default preset's folder: also time the general export's pass")
    ap.add_argument("--map", default="none", choices=["none", "beta", "sigma_s"], help="with --tables: the parameter map")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as out:
        export_webgl(a.dir, Path(out) / "material")
        mounts, query = {"/material/": Path(out) / "material"}, ""
        if a.tables:
            subprocess.run([twoscale_binary(), "export", "--format", "webgl", "--preset", "default", "--tables", str(a.tables.parent),
                            "--out", str(Path(out) / "tables")], check=True, capture_output=True)
            mounts["/tables/"] = Path(out) / "tables"
            m = json.loads((a.dir / "epd_g1.manifest.json").read_text())["material"]
            params = {k: m.get(k) or d for k, d in (("beta", 0), ("p", 0), ("sigma_s", 0.0), ("b", 1.0), ("c", 2.0))}
            query = "&tables=tables/tables.json&material=material/material.json&map=" + a.map + "".join(f"&{k}={v}" for k, v in params.items())
        with Server({**mounts, "/": HERE}) as srv, Browser() as b:
            b.open(srv.url(f"/index.html?bench=1&n={a.n}&size={a.size}&lobe={a.lobe}&energy={a.energy}{query}"))
            b.wait("document.body.dataset.ready === '1' || document.getElementById('error').textContent", timeout=600)
            err = b.eval("document.getElementById('error').textContent")
            if err:
                sys.exit(f"bench: {err}")
            print(json.dumps(json.loads(b.eval("document.getElementById('bench').textContent")), indent=1))


if __name__ == "__main__":
    main()
