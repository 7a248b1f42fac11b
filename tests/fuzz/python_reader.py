"""Runs the Python reader's command line once per case, each in a forked child process (numpy and
h5py are imported once, in the parent), for tests/fuzz.rs.

    python_reader.py READER.py TIMEOUT_SECONDS < cases

Each line of stdin is a JSON list of arguments (`lookup FILE.h5 NAME=VALUE ...`); each line of
stdout is the JSON object {"code": exit status or null, "signal": number or null, "hang": bool,
"stdout": ..., "stderr": ...} of that case, in order.
"""
import importlib.util
import json
import os
import signal
import sys
import tempfile
import time
import traceback


def run(reader, args, timeout):
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        pid = os.fork()
        if pid == 0:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            try:
                code = reader.main(["twoscale_tables.py", *args])
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
    spec = importlib.util.spec_from_file_location("twoscale_tables", sys.argv[1])
    reader = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(reader)
    timeout = float(sys.argv[2])
    for line in sys.stdin:
        print(json.dumps(run(reader, json.loads(line), timeout)), flush=True)


if __name__ == "__main__":
    main()
