"""Where the shared data are (merl-nbrdf/, published-fits/, rgl/ and their README.md; /work/shared/data on the
project's machine): outside the repository, found the same way by every test and script."""
import os
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def local_origin(repo=REPO):
    """The folder the git remote `origin` of repo is, when it is a local path or a file:// URL; else None."""
    try:
        res = subprocess.run(["git", "-C", str(repo), "remote", "get-url", "origin"], capture_output=True, text=True)
    except OSError:  # no git
        return None
    url = res.stdout.strip()
    if res.returncode != 0 or not url:
        return None
    if url.startswith("file://"):
        url = url[len("file://"):]
    elif "://" in url or ":" in url.split("/")[0]:  # a URL or scp's host:path
        return None
    path = Path(url) if Path(url).is_absolute() else repo / url
    return path.resolve() if path.is_dir() else None


def shared_data(repo=REPO):
    """The shared data folder: $TWOSCALE_DATA if set, else <repo>/../shared/data, else <origin>/../shared/data where
    `origin` is a local folder (a clone made elsewhere with `git clone`). FileNotFoundError, one line, if none is."""
    given = os.environ.get("TWOSCALE_DATA")
    if given:
        if not Path(given).is_dir():
            raise FileNotFoundError(f"TWOSCALE_DATA={given}: no such directory")
        return Path(given).resolve()
    tried = [Path(repo).resolve().parent / "shared/data"]
    origin = local_origin(repo)
    if origin is not None:
        tried.append(origin.parent / "shared/data")
    for path in tried:
        if path.is_dir():
            return path
    where = " nor ".join(str(p) for p in tried)
    raise FileNotFoundError(f"no shared data: TWOSCALE_DATA is not set, and neither {where} is a directory" if len(tried) > 1 else
                            f"no shared data: TWOSCALE_DATA is not set, {where} is not a directory and origin is not a local folder")
