"""The reader package's tests: `--build-root` names a build root holding the golden tables
(pipeline/tables/golden/make.sh builds one; `make test` passes the shared test tables)."""
from pathlib import Path

import pytest


def pytest_addoption(parser):
    parser.addoption("--build-root", type=Path, help="a build root of pipeline/tables/golden/make.sh")
    parser.addoption("--vectors", type=Path, help="the golden vectors (default: pipeline/tables/golden/vectors.json)")


@pytest.fixture(scope="session")
def build_root(request):
    root = request.config.getoption("--build-root")
    if root is None:
        pytest.skip("no --build-root given")
    return root


@pytest.fixture(scope="session")
def vectors(request):
    return request.config.getoption("--vectors") or Path(__file__).resolve().parents[2] / "golden" / "vectors.json"
