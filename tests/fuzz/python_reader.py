"""Runs the Python reader's command line (`python -m twoscale_tables`, the installed package) once
per case, each in a forked child process (numpy, h5py and the package are imported once, in the
parent), for tests/suite/fuzz.rs.

    python_reader.py TIMEOUT_SECONDS < cases

Each line of stdin is a JSON list of arguments (`lookup FILE.h5 NAME=VALUE ...`); each line of
stdout is the JSON object {"code": exit status or null, "signal": number or null, "hang": bool,
"stdout": ..., "stderr": ...} of that case, in order.
"""
import json
import os
import signal
import sys
import tempfile
import time
import traceback

from twoscale_tables.__main__ import main as reader_main


def run(args, timeout):
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        pid = os.fork()
        if pid == 0:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            try:
                code = reader_main(["python -m twoscale_tables", *args])
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else 1
            except BaseException:  # as the interpreter would: the traceback, exit status 1
                traceback.print_exc()
                code = 1
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
        start = time.monotonic()
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                break
            if time.monotonic() - start > timeout:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                return {"code": None, "signal": None, "hang": True, "stdout": "", "stderr": ""}
            time.sleep(0.002)
        text = []
        for f in (out, err):
            f.seek(0)
            text.append(f.read().decode("utf-8", "replace"))
        return {
            "code": os.WEXITSTATUS(status) if os.WIFEXITED(status) else None,
            "signal": os.WTERMSIG(status) if os.WIFSIGNALED(status) else None,
            "hang": False,
            "stdout": text[0],
            "stderr": text[1],
        }


def main():
    timeout = float(sys.argv[1])
    for line in sys.stdin:
        print(json.dumps(run(json.loads(line), timeout)), flush=True)


if __name__ == "__main__":
    main()
