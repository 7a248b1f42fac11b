"""Fixtures of `twoscale fit`'s recovery tests: the default preset's general tables (--tables, else built by
`twoscale build` into target/tmp/pytest-tables) and the cache of synthetic targets (target/tmp/merl-cache)."""
import subprocess
from pathlib import Path

import pytest
from twoscale_c import twoscale_binary  # runtimes/testing (`make pyenv` installs it)

REPO = Path(__file__).resolve().parents[3]


def pytest_addoption(parser):
    parser.addoption("--tables", type=Path, help="the default preset's folder (the general tables)")


@pytest.fixture(scope="session")
def tables(request):
    given = request.config.getoption("--tables")
    if given:
        return given
    out = REPO / "target/tmp/pytest-tables"
    res = subprocess.run([twoscale_binary(), "build", "--quiet", "--out", str(out), "--preset", "default"], capture_output=True, text=True)
    if res.returncode != 0:
        pytest.exit(f"twoscale build: {res.stderr.strip()}", returncode=1)
    return out / "default"


@pytest.fixture(scope="session")
def merl_cache():
    path = REPO / "target/tmp/merl-cache"
    path.mkdir(parents=True, exist_ok=True)
    return path
