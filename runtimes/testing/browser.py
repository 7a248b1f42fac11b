"""Headless Chromium for the WebGL runtime's tests: a static server on 127.0.0.1 and a page run.

    from browser import Server, run_page
    with Server({"/runtime/": REPO / "runtimes/webgl", "/data/": tmp}) as srv:
        page = run_page(srv.url("/runtime/tests/harness.html?case=/data/case.json"))
        page.text("result")     # the text of the element with id "result" once the page ran
        page.console            # the console messages and page errors Chromium logged

Chromium is Debian's (`make browser` installs it), run with SwiftShader's WebGL2 (the flags below: recent
Chrome does not fall back to it by itself), no crash reporter, and its profile and HOME in a temporary folder.
`--dump-dom` prints the DOM after `--virtual-time-budget` milliseconds of virtual time, so a page reports by
writing into elements; GPU work and fetches run in real time before the budget ends. Past `timeout` (real
seconds) Chromium's whole process group is killed and run_page raises, naming the URL. The server serves each
prefix from its folder, nothing else, with the MIME types an ES module and its fetches need, and no caching.
"""
import contextlib
import html
import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--enable-unsafe-swiftshader", "--use-gl=angle", "--use-angle=swiftshader",
         "--disable-gpu-sandbox", "--no-first-run", "--no-default-browser-check", "--disable-extensions",
         "--enable-logging=stderr", "--v=0", "--disable-crash-reporter", "--disable-breakpad", "--disable-dev-shm-usage"]
MIME = {".js": "text/javascript", ".mjs": "text/javascript", ".glsl": "text/plain", ".json": "application/json",
        ".bin": "application/octet-stream", ".html": "text/html", ".css": "text/css"}


def chromium():
    """Debian's chromium (or $CHROMIUM)."""
    exe = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if not exe:
        raise RuntimeError("chromium not found: `make browser` installs Debian's chromium")
    return exe


def export_webgl(folder, out):
    """`twoscale export --format webgl --dir folder --out out` (out/material.json, its binaries, SHA256SUMS); out.
    A failed export raises, with twoscale's one-line error."""
    from twoscale_c import twoscale_binary

    res = subprocess.run([twoscale_binary(), "export", "--quiet", "--format", "webgl", "--dir", str(folder), "--out", str(out)],
                         capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"twoscale export --format webgl --dir {folder}: {res.stderr.strip()}")
    return Path(out)


class _Handler(SimpleHTTPRequestHandler):
    def __init__(self, *args, mounts, **kwargs):
        self.mounts = mounts
        super().__init__(*args, **kwargs)

    def translate_path(self, path):
        path = path.split("?", 1)[0].split("#", 1)[0]
        for prefix, folder in self.mounts.items():
            if path.startswith(prefix):
                rel = Path(*[p for p in path[len(prefix):].split("/") if p not in ("", ".", "..")])
                return str(Path(folder) / rel)
        return "/nonexistent"

    def guess_type(self, path):
        return MIME.get(Path(path).suffix, "application/octet-stream")

    def end_headers(self):
        self.send_header("Cache-Control", "no-store")
        super().end_headers()

    def log_message(self, *args):
        pass


class Server:
    """A threaded HTTP server on 127.0.0.1 (a free port) serving {url prefix: folder}."""

    def __init__(self, mounts):
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), partial(_Handler, mounts={k: Path(v) for k, v in mounts.items()}))
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def url(self, path):
        return f"http://127.0.0.1:{self.httpd.server_address[1]}{path}"

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.httpd.shutdown()
        self.httpd.server_close()


class Page:
    """What a page run left: the DOM after the budget, Chromium's console log, and a screenshot's path."""

    def __init__(self, dom, log, screenshot=None):
        self.dom = dom
        self.log = log
        self.screenshot = screenshot
        # "CONSOLE(line)" / "Uncaught ..." lines Chromium prints for console.* and page errors
        self.console = [line for line in log.splitlines() if "CONSOLE" in line or "Uncaught" in line]

    def text(self, element_id):
        """The text of the element with this id (HTML entities decoded), or None."""
        m = re.search(r'<[^>]*\bid="' + re.escape(element_id) + r'"[^>]*>(.*?)</', self.dom, re.S)
        return html.unescape(m.group(1)) if m else None


def run_page(url, budget_ms=20000, timeout=120, size=(800, 600), screenshot=None):
    """Loads url in headless Chromium; returns a Page (with screenshot: a PNG of the window there). Raises
    RuntimeError naming the URL if Chromium has not exited after timeout seconds (its process group killed)."""
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:
        args = [chromium(), *FLAGS, f"--user-data-dir={profile}", f"--virtual-time-budget={budget_ms}",
                f"--window-size={size[0]},{size[1]}"]
        args += [f"--screenshot={screenshot}"] if screenshot else ["--dump-dom"]
        # HOME too: nothing in ~/.config or ~/.cache; a session of its own, so that a timeout kills every child
        proc = subprocess.Popen([*args, url], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env={**os.environ, "HOME": profile}, start_new_session=True)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            try:  # what it logged, unless something outside its group still holds the pipes
                err = proc.communicate(timeout=5)[1]
            except subprocess.TimeoutExpired:
                err = ""
            raise RuntimeError(f"chromium did not finish {url} within {timeout} s (a virtual time budget of {budget_ms} ms): "
                               f"killed; its log ends {err[-1000:]!r}") from None
    if proc.returncode != 0:
        raise RuntimeError(f"chromium exited with {proc.returncode} on {url}: {err[-2000:]}")
    return Page(out, err, screenshot)
