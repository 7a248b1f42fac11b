"""Fixtures of the runtimes' tests: the test materials' folders, a bundle of them, the default
preset's tables, the C BRDF's compile cache, and Mitsuba variants (as Mitsuba 3's own conftest.py).

The tables come from the options (`make test` passes the shared test builds), else they are built
here with `twoscale` ($TWOSCALE_BIN, else target/release/twoscale) into target/tmp/pytest-tables
(an incremental build: a second run does no work)."""
import subprocess
from pathlib import Path

import pytest
from twoscale_c import twoscale_binary

REPO = Path(__file__).resolve().parent.parent

# The Mitsuba variants `make test` installs that the BSDF supports (spectral, unpolarised).
SPECTRAL_VARIANTS = ["scalar_spectral", "llvm_ad_spectral"]


def pytest_addoption(parser):
    parser.addoption("--materials", type=Path, help="the folder scene-test_materials of a build of runtimes/testing/test_materials.toml")
    parser.addoption("--tables", type=Path, help="the default preset's folder (the reader's lookups, the numpy model)")
    parser.addoption("--c-cache", type=Path, help="where the C BRDF's compiled materials are kept (default: a temporary folder)")


def _build(args, folder):
    out = REPO / "target/tmp/pytest-tables"
    res = subprocess.run([twoscale_binary(), "build", "--quiet", "--out", str(out), *args], capture_output=True, text=True)
    if res.returncode != 0:
        pytest.exit(f"twoscale build {' '.join(args)}: {res.stderr.strip()}", returncode=1)
    return out / folder


@pytest.fixture(scope="session")
def materials(request):
    """The folder of runtimes/testing/test_materials.toml's material folders."""
    given = request.config.getoption("--materials")
    return given or _build(["--scene", str(REPO / "runtimes/testing/test_materials.toml")], "scene-test_materials")


@pytest.fixture(scope="session")
def tables(request):
    """The default preset's tables."""
    return request.config.getoption("--tables") or _build(["--preset", "default"], "default")


@pytest.fixture(scope="session")
def bundle(materials, tmp_path_factory):
    """A bundle of the test materials (`twoscale bundle`)."""
    out = tmp_path_factory.mktemp("bundle")
    res = subprocess.run([twoscale_binary(), "bundle", "--quiet", "--dir", str(materials), "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return next(out.glob("*.tar.gz"))


@pytest.fixture(scope="session")
def c_cache(request, tmp_path_factory):
    return request.config.getoption("--c-cache") or tmp_path_factory.mktemp("c-brdf-cache")


def _set_variant(name):
    import mitsuba as mi

    mi.set_variant(name)
    # The BSDF warns when a folder covers less than Mitsuba's wavelengths (chi13, furnace6).
    mi.set_log_level(mi.LogLevel.Error)
    return name


@pytest.fixture
def variant_llvm_ad_spectral():
    return _set_variant("llvm_ad_spectral")


@pytest.fixture
def variant_llvm_ad_rgb():
    """For mitsuba.chi2 over the C BRDF (which needs no spectral variant)."""
    return _set_variant("llvm_ad_rgb")


@pytest.fixture(params=SPECTRAL_VARIANTS)
def variants_all_spectral(request):
    return _set_variant(request.param)
