"""The BSDF's `public_key` (docs/file_contract.md "Signatures"): a material bundle (`twoscale bundle --dir`)
signed by Debian's minisign loads with its key and evaluates as its folder; another key, a key without a
signature and a key with a folder are each one TwoScaleError."""
import hashlib
import json
import math
import shutil
import subprocess
import tarfile
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
import twoscale_mitsuba  # noqa: F401  (registers the plugin for every spectral variant)
from checks import report
from twoscale_c import minisign, twoscale_binary

MATERIAL = "rand1"
VERSIONS_LOCK = Path(__file__).resolve().parents[3] / "manifests/versions.lock"


@pytest.fixture(scope="module")
def signed(materials, tmp_path_factory):
    """(the bundle of MATERIAL's folder signed by key k, k.pub, other.pub)."""
    out = tmp_path_factory.mktemp("signed")
    res = subprocess.run([twoscale_binary(), "bundle", "--quiet", "--dir", str(materials / MATERIAL), "--out", str(out)],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    path = next(out.glob("*.tar.gz"))
    with tarfile.open(path) as tar:
        info = json.load(tar.extractfile(f"{path.name[: -len('.tar.gz')]}/bundle.json"))
    preset = json.loads((materials / MATERIAL / "epd_g1.manifest.json").read_text())["preset"]
    assert info["preset"] == preset, (info["preset"], preset)
    for name in ("k", "other"):
        minisign("-G", "-W", "-f", "-p", f"{name}.pub", "-s", f"{name}.key", cwd=out)
    # the comment `twoscale bundle --sign` writes: versions_lock_sha256 the SHA-256 of the version's versions.lock line
    line = next(line for line in VERSIONS_LOCK.read_text().splitlines() if line.split(" ")[0] == info["version"])
    text = (f"twoscale-bundle/1 file={path.name} version={info['version']} preset={preset} "
            f"versions_lock_sha256={hashlib.sha256(line.encode()).hexdigest()}")
    minisign("-S", "-s", "k.key", "-m", path.name, "-t", text, cwd=out)
    return path, out / "k.pub", out / "other.pub"


def evaluate(d):
    """The BSDF of dict d (F = 1) at a few (wi, wo) at 550 nm, with its cosine."""
    bsdf = mi.load_dict({"type": "twoscale", "fresnel": "one", **d})
    wi = np.array([[0.3, 0.0, math.sqrt(0.91)], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]], dtype=np.float32)
    wo = np.array([[-0.28, 0.05, math.sqrt(1 - 0.0809)], [0.1, -0.5, math.sqrt(0.74)], [0.6, 0.0, 0.8]], dtype=np.float32)
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(*(mi.Float(wi[:, j]) for j in range(3)))
    si.wavelengths = mi.Spectrum(550.0)
    value = bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*(mi.Float(wo[:, j]) for j in range(3))))
    return np.asarray(value, dtype=np.float64)


def refusal(d):
    """The last line of the error loading the BSDF dict d (Mitsuba re-raises the plugin's after its traceback)."""
    try:
        mi.load_dict({"type": "twoscale", "fresnel": "one", **d})
    except Exception as e:
        return str(e).strip().splitlines()[-1]
    return None


def test_signature_verified_evaluates_as_folder(variant_llvm_ad_spectral, materials, signed):
    path, pub, _ = signed
    folder = evaluate({"tables": str(materials / MATERIAL)})
    assert np.all(np.isfinite(folder)) and folder.max() > 0.0, folder
    for key in (str(pub), pub.read_text().splitlines()[1]):  # the .pub file, its base64 line
        same = np.array_equal(evaluate({"tables": str(path), "public_key": key}), folder)
        report(same, f"signature: {path.name} with public_key {key[:60]} evaluates as the folder {MATERIAL}: {folder.ravel()[:4]}")


def test_signature_refusals(variant_llvm_ad_spectral, materials, signed, tmp_path):
    path, pub, other = signed
    msg = refusal({"tables": str(path), "public_key": str(other)})
    report(msg is not None and msg.startswith("TwoScaleError: ") and path.name in msg and "not by the public key's" in msg,
           f"signature: another key is refused: {msg}")
    unsigned = shutil.copy(path, tmp_path / path.name)  # the same bundle without its .minisig
    msg = refusal({"tables": str(unsigned), "public_key": str(pub)})
    report(msg is not None and msg.startswith("TwoScaleError: ") and path.name in msg and "no signature" in msg,
           f"signature: a key for a bundle without a signature is refused: {msg}")
    msg = refusal({"tables": str(materials / MATERIAL), "public_key": str(pub)})
    report(msg is not None and msg.startswith("TwoScaleError: ") and "is not a bundle" in msg,
           f"signature: public_key with a folder is refused: {msg}")
