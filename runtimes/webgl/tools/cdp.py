"""Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe), in real time.

The explorer's bench and its README screenshot need what `--dump-dom --virtual-time-budget` cannot give:
under virtual time performance.now() does not advance while the GPU works (every timing reads 0), and the
moment of a `--screenshot` is the budget's, not the page's. Here the page runs on the wall clock; a script
waits for a JavaScript condition and then reads a value or takes a screenshot.

    with Browser(size=(1200, 800)) as b:
        b.open(url)
        b.wait("document.body.dataset.ready === '1'", timeout=120)
        print(b.eval("document.getElementById('bench').textContent"))
        b.screenshot("out.png")
"""
import base64
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

from browser import FLAGS, chromium  # runtimes/testing: the tests' flags (headless, SwiftShader's WebGL2)


class Browser:
    def __init__(self, size=(1200, 800)):
        self.size = size
        self.next_id = 0
        self.session = None

    def __enter__(self):
        self.profile = tempfile.TemporaryDirectory()
        to_child, self.out = os.pipe()   # we write commands, Chromium reads fd 3
        self.inp, from_child = os.pipe()  # Chromium writes fd 4, we read

        def fds():  # in the child: the pipe's ends on fds 3 and 4, as --remote-debugging-pipe expects
            os.dup2(to_child, 3)
            os.dup2(from_child, 4)

        args = [chromium(), *FLAGS, "--remote-debugging-pipe", f"--user-data-dir={self.profile.name}",
                f"--window-size={self.size[0]},{self.size[1]}", "about:blank"]
        self.proc = subprocess.Popen(args, preexec_fn=fds, pass_fds=(3, 4), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_child)
        os.close(from_child)
        self.buf = b""
        target = next(t for t in self.send("Target.getTargets", session=False)["targetInfos"] if t["type"] == "page")
        self.session = self.send("Target.attachToTarget", {"targetId": target["targetId"], "flatten": True}, session=False)["sessionId"]
        self.send("Emulation.setDeviceMetricsOverride", {"width": self.size[0], "height": self.size[1], "deviceScaleFactor": 1, "mobile": False})
        return self

    def __exit__(self, *exc):
        try:
            self.send("Browser.close", session=False)
            self.proc.wait(timeout=10)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        os.close(self.out)
        os.close(self.inp)
        self.profile.cleanup()

    def send(self, method, params=None, session=True):
        """One command; its result (events in between are dropped)."""
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self.out, json.dumps(msg).encode() + b"\0")
        while True:
            while b"\0" not in self.buf:
                chunk = os.read(self.inp, 1 << 20)
                if not chunk:
                    raise RuntimeError("chromium closed the DevTools pipe")
                self.buf += chunk
            raw, self.buf = self.buf.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def open(self, url):
        self.send("Page.navigate", {"url": url})

    def eval(self, expression):
        """The value of a JavaScript expression (a promise is awaited)."""
        res = self.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True, "returnByValue": True})
        if "exceptionDetails" in res:
            raise RuntimeError(f"{expression}: {res['exceptionDetails'].get('text')}")
        return res["result"].get("value")

    def wait(self, condition, timeout=120, poll=0.25):
        """Polls a JavaScript condition until it is truthy; its value (TimeoutError after timeout seconds)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                value = self.eval(f"(() => {{ try {{ return {condition}; }} catch (e) {{ return null; }} }})()")
            except RuntimeError:
                value = None  # the page is between documents
            if value:
                return value
            time.sleep(poll)
        raise TimeoutError(f"after {timeout} s: {condition}")

    def screenshot(self, path):
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        Path(path).write_bytes(base64.b64decode(data))
