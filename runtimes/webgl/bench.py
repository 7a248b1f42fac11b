"""The explorer's speed measure: the per-pixel cost of the twoscale sphere pass against a GGX pass drawn by the
same page (index.html?bench=1: the same spectral loop and tone mapping, only the BRDF differs), in headless
Chromium on the wall clock (cdp.py). Prints the page's JSON.

    .venv/bin/python runtimes/webgl/bench.py --dir tables-out/scene-render_materials/nickel [--n 20 --size 256 --lobe fit]

Without a GPU Chromium renders with SwiftShader, a CPU rasteriser: the ratio is the result, not the times.
"""
import argparse
import json
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "testing"))
from browser import Server, export_webgl  # noqa: E402
from cdp import Browser  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", required=True, type=Path, help="a material folder (built tables)")
    ap.add_argument("--n", type=int, default=20, help="draws of each pass")
    ap.add_argument("--size", type=int, default=256, help="the passes' resolution (size x size)")
    ap.add_argument("--lobe", default="exact", choices=["exact", "fit"])
    ap.add_argument("--energy", default="single", choices=["single", "compensated"])
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as out:
        export_webgl(a.dir, out)
        with Server({"/material/": out, "/": HERE}) as srv, Browser() as b:
            b.open(srv.url(f"/index.html?bench=1&n={a.n}&size={a.size}&lobe={a.lobe}&energy={a.energy}"))
            b.wait("document.body.dataset.ready === '1' || document.getElementById('error').textContent", timeout=600)
            err = b.eval("document.getElementById('error').textContent")
            if err:
                sys.exit(f"bench: {err}")
            print(json.dumps(json.loads(b.eval("document.getElementById('bench').textContent")), indent=1))


if __name__ == "__main__":
    main()
