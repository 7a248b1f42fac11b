"""runtimes/testing/nbrdf.py: the MERL files of the published NBRDF networks (Sztrajman et al. 2021; the shared data's
merl-nbrdf/ and its README, found by shared_data.py).

- For a metal (steel: the sharpest peak), a paint (white-paint: the most bins where exp(y) - 1 < 0, stored 0) and a
  dark fabric (black-fabric: the smallest values), the file nbrdf.py writes, read back by merl.read, against the
  network evaluated here sample by sample in plain Python: weights read with h5py, wi and wo built by rotation
  matrices (wi = R_y(theta_h) R_z(phi_d) R_y(theta_d) z, wo = R_y(theta_h) R_z(phi_d + pi) R_y(theta_d) z, its mirror
  about h), the network's input recovered from (wi, wo) as the authors' io_to_hd does (h = normalize(wi + wo), the
  difference vector wi rotated by -phi_h about z then -theta_h about y); at 1,000 random bins and at every bin the file
  stores 0, to 1e-9 relative (max(exp(y) - 1, 0): 0 exactly where the network is negative). The bins marked negative
  are exactly those where wi_z or wo_z is below 1e-6 (merl.py's rule), over the whole file.
- A missing file, an architecture that is not the NBRDF network, a missing dataset, a wrong shape, a file that is
  not HDF5: one-line ValueErrors; `python -m nbrdf` with a bad input among good ones: exit status 2, one line on
  stderr, nothing written.

    pytest pipeline/fit/tests/test_nbrdf.py     (about 12 s on 2 cores)"""
import math
import shutil
import subprocess
import sys

import h5py
import merl
import nbrdf
import numpy as np
import pytest
from shared_data import shared_data

MATERIALS = ["steel", "white-paint", "black-fabric"]
SCALES = (1.0 / 1500, 1.15 / 1500, 1.66 / 1500)


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return ((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c))


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))


def apply(*ms_and_v):
    """m1 (m2 (... v))."""
    *ms, v = ms_and_v
    for m in reversed(ms):
        v = tuple(m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2] for r in range(3))
    return v


def bin_directions(i, j, k):
    """wi, wo of MERL's bin (i, j, k), by rotation matrices."""
    th, td, pd = (i / 90) ** 2 * math.pi / 2, j * math.pi / 180, k * math.pi / 180
    z = (0.0, 0.0, 1.0)
    return apply(rot_y(th), rot_z(pd), rot_y(td), z), apply(rot_y(th), rot_z(pd + math.pi), rot_y(td), z)


def network_input(wi, wo):
    """(hx, 0, hz, dx, dy, dz) from (wi, wo), as the authors' io_to_hd and their renderer (phi_h then set to 0)."""
    s = [a + b for a, b in zip(wi, wo)]
    n = math.sqrt(sum(x * x for x in s))
    h = [x / n for x in s]
    theta_h = math.atan2(math.hypot(h[0], h[1]), h[2])
    # h on the normal (theta_h = 0): phi_h is rounding noise of wi + wo, and phi_d relative to it would be too; MERL's
    # bins take phi_h = 0 there (h = z exactly), so does this
    phi_h = math.atan2(h[1], h[0]) if math.hypot(h[0], h[1]) > 1e-12 else 0.0
    d = apply(rot_y(-theta_h), rot_z(-phi_h), wi)
    return [math.sin(theta_h), 0.0, math.cos(theta_h), *d]


def weights(path):
    """[(kernel rows, bias)] of the three Dense layers, as Python floats."""
    with h5py.File(path, "r") as f:
        return [(f[f"dense_{n}/dense_{n}/kernel:0"][()].tolist(), f[f"dense_{n}/dense_{n}/bias:0"][()].tolist()) for n in (1, 2, 3)]


def network(layers, x):
    """exp(y) - 1 of the network at x, one multiply-add at a time."""
    for n, (kernel, bias) in enumerate(layers):
        y = [bias[o] + sum(x[r] * kernel[r][o] for r in range(len(x))) for o in range(len(bias))]
        x = [max(v, 0.0) for v in y] if n < 2 else y
    return [math.expm1(v) for v in x]


@pytest.mark.parametrize("name", MATERIALS)
def test_the_file_is_the_network_at_merl_bins(name, tmp_path):
    h5 = shared_data() / "merl-nbrdf" / f"{name}.h5"
    subprocess.run([sys.executable, "-m", "nbrdf", str(h5), "--out", str(tmp_path)], check=True, capture_output=True)
    rho = merl.read(tmp_path / f"{name}.binary")  # NaN where stored negative
    marked = np.isnan(rho)
    assert (marked == marked[0]).all(), "a bin marked in some channels only"
    # below the horizon over the whole grid: the z rows of the rotations above, wi_z = cos th cos td - sin th sin td cos pd
    # and wo_z = cos th cos td + sin th sin td cos pd
    th = ((np.arange(90) / 90) ** 2 * math.pi / 2)[:, None, None]
    td, pd = (np.arange(90) * math.pi / 180)[None, :, None], (np.arange(180) * math.pi / 180)[None, None, :]
    a, b = np.cos(th) * np.cos(td), np.sin(th) * np.sin(td) * np.cos(pd)
    below = (a - b < 1e-6) | (a + b < 1e-6)
    assert (marked[0] == below).all(), f"{(marked[0] != below).sum()} bins marked otherwise than below the horizon"
    # 1,000 random bins and every bin stored 0 (where exp(y) - 1 < 0)
    rng = np.random.default_rng(2021)
    flat = np.union1d(rng.choice(rho[0].size, 1000, replace=False), np.flatnonzero((rho == 0).any(0)))
    layers, worst, zeros = weights(h5), 0.0, 0
    for i, j, k in zip(*np.unravel_index(flat, merl.DIMS)):
        wi, wo = bin_directions(i, j, k)
        if wi[2] < 1e-6 or wo[2] < 1e-6:
            continue  # marked: checked above
        want = network(layers, network_input(wi, wo))
        for c in range(3):
            got, expect = rho[c, i, j, k], max(want[c], 0.0)
            zeros += expect == 0.0
            assert abs(got - expect) <= 1e-9 * expect, f"bin ({i}, {j}, {k}) channel {c}: {got} in the file, {want[c]} from the network"
            worst = max(worst, abs(got - expect) / expect if expect else 0.0)
    print(f"{name}: {len(flat)} bins, {int((~below).sum())} valid, {zeros} values where exp(y) - 1 < 0 (stored 0), "
          f"largest relative difference {worst:.1e}")


def test_bad_inputs_are_refused(tmp_path):
    src = shared_data() / "merl-nbrdf"
    for ext in ("h5", "json"):
        shutil.copy(src / f"steel.{ext}", tmp_path / f"good.{ext}")

    def variant(name, json_edit=None, h5_edit=None):
        shutil.copy(tmp_path / "good.json", tmp_path / f"{name}.json")
        shutil.copy(tmp_path / "good.h5", tmp_path / f"{name}.h5")
        if json_edit:
            (tmp_path / f"{name}.json").write_text(json_edit((tmp_path / "good.json").read_text()))
        if h5_edit:
            with h5py.File(tmp_path / f"{name}.h5", "r+") as f:
                h5_edit(f)
        return tmp_path / f"{name}.h5"

    def refused(path, needle):
        with pytest.raises(ValueError) as e:
            nbrdf.load(path)
        assert needle in str(e.value) and "\n" not in str(e.value), str(e.value)

    def reshape(f):
        del f["dense_3/dense_3/kernel:0"]
        f["dense_3/dense_3/kernel:0"] = np.zeros((21, 4), np.float32)

    refused(tmp_path / "absent.h5", "absent.h5: no such file")
    (tmp_path / "lone.h5").write_bytes((tmp_path / "good.h5").read_bytes())
    refused(tmp_path / "lone.h5", "lone.json: no such file")
    refused(variant("units", json_edit=lambda t: t.replace('"units": 21', '"units": 20', 1)), "not the NBRDF network")
    refused(variant("act", json_edit=lambda t: t.replace('"activation": "linear"', '"activation": "relu"')), "not the NBRDF network")
    refused(variant("nojson", json_edit=lambda t: t[:100]), "not readable as JSON")
    refused(variant("nobias", h5_edit=lambda f: f.__delitem__("dense_2/dense_2/bias:0")), "no dataset dense_2/dense_2/bias:0")
    refused(variant("shape", h5_edit=reshape), "dense_3/dense_3/kernel:0 is float32 (21, 4), not float (21, 3)")
    variant("text").write_text("not HDF5")
    refused(tmp_path / "text.h5", "not readable as HDF5")
    assert nbrdf.load(tmp_path / "good.h5").layers[2][0].shape == (21, 3)

    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "nbrdf", str(tmp_path / "good.h5"), str(tmp_path / "shape.h5"), "--out", str(out)],
                         capture_output=True, text=True)
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "shape.h5" in res.stderr, res.stderr
    assert not out.exists(), f"a refused run wrote {list(out.iterdir())}"
