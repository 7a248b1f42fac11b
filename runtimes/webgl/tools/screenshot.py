"""The explorer's picture for the README: one material folder exported (`twoscale export --format webgl`),
the page opened in headless Chromium (cdp.py, real time) and captured once every view has drawn and the
sphere's sky has its samples.

    .venv/bin/python runtimes/webgl/tools/screenshot.py --dir tables-out/scene-render_materials/b0.5 --out docs/renders/explorer.png
"""
import argparse
import sys
import tempfile
from pathlib import Path

from browser import Server, export_webgl  # runtimes/testing (`make pyenv` installs it)
from cdp import Browser  # beside this script

HERE = Path(__file__).resolve().parents[1]  # the runtime's folder (these tools are in its tools/)

# the sphere is done (all its sky samples in) and every plot drawn, or the page failed
DONE = ("(() => { const s = JSON.parse(document.getElementById('status-json').textContent || '{}');"
        " return (s.ready && s.sphere && s.sphere.done) || s.errors?.length; })()")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", required=True, type=Path, help="a material folder (built tables)")
    ap.add_argument("--out", type=Path, default=Path("docs/renders/explorer.png"))
    ap.add_argument("--size", default="1200x800", help="the window, WxH")
    ap.add_argument("--query", default="theta=25&spp=128&exposure=-1", help="the page's initial controls (index.html's query string)")
    a = ap.parse_args()
    w, h = map(int, a.size.split("x"))
    with tempfile.TemporaryDirectory() as out:
        export_webgl(a.dir, out)
        with Server({"/material/": out, "/": HERE}) as srv, Browser(size=(w, h)) as b:
            b.open(srv.url(f"/index.html?{a.query}"))
            b.wait(DONE, timeout=600)
            err = b.eval("document.getElementById('error').textContent")
            if err:
                sys.exit(f"screenshot: the page failed: {err}")
            a.out.parent.mkdir(parents=True, exist_ok=True)
            b.screenshot(a.out)
    print(a.out)


if __name__ == "__main__":
    main()
