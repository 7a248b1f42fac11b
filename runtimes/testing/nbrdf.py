"""MERL files of the published NBRDF networks (Sztrajman et al. 2021, "Neural BRDF Representation and Importance
Sampling"; the shared data's merl-nbrdf/, its README): each network evaluated at MERL's bins (merl.py) and written by
merl.write. The files stand in for the real MERL measurements: close to them, smoother at the sharpest peaks, not
equal to them.

The network (NAME.h5, Keras 2.2.4 weights; NAME.json, its architecture, checked against this before use):
x = (hx, hy, hz, dx, dy, dz), the half vector with phi_h = 0, h = (sin theta_h, 0, cos theta_h), and the difference
vector d = (sin theta_d cos phi_d, sin theta_d sin phi_d, cos theta_d); dense_1 (6 -> 21, ReLU), dense_2 (21 -> 21,
ReLU), dense_3 (21 -> 3, linear), each y = x kernel + bias with `dense_k/dense_k/kernel:0` [in, out] and `bias:0`
[out]; then rho = exp(y) - 1 in 1/sr, RGB. The float32 weights are evaluated in float64.

The file: rho at merl.py's valid bins (wi_z and wo_z >= 1e-6 at the bin's directions, as merl.write marks the others
-1 and merl.rs skips them), max(rho, 0) there: the network's exp(y) - 1 is negative where y < 0 (in 14 of the 50
networks, at 3 to 2,013 of the 1,111,428 valid bins, mostly at grazing theta_d, down to -0.08), which a MERL reader
would take for "below the horizon"; 0 is what the authors' own renderer makes of it (their Mitsuba plugin's nn.h:
max(exp(y) - 1, 0)).

    .venv/bin/python -m nbrdf /work/shared/data/merl-nbrdf/steel.h5 [MORE.h5 ...] --out target/merl-nbrdf

writes DIR/NAME.binary for each (1-2 s each on 2 cores: the 50 in 62 s); every input is read and checked before
anything is written, and the files are renamed into place only once all are written: a bad input is one line on
stderr, exit status 2, and no file.
"""
import argparse
import base64
import binascii
import json
import os
import sys
import time
from pathlib import Path
from typing import NamedTuple

import h5py
import merl
import numpy as np

# (name, inputs, units, activation) of the three Dense layers; a Lambda (exp(x) - 1) follows them.
LAYERS = (("dense_1", 6, 21, "relu"), ("dense_2", 21, 21, "relu"), ("dense_3", 21, 3, "linear"))
# Rows per pass through the network: its [rows, 21] float64 activations are 11 MB.
CHUNK = 1 << 16


class Net(NamedTuple):
    path: Path
    layers: tuple  # ((kernel [in, out], bias [out]) float64) per Dense layer, LAYERS' order


def check_architecture(path):
    """ValueError unless the Keras JSON at path is LAYERS followed by a Lambda whose marshalled code calls exp."""
    try:
        model = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: not readable as JSON ({e})") from None
    try:
        layers = model["config"]["layers"] if isinstance(model["config"], dict) else model["config"]
        got = []
        for layer in layers:
            conf = layer["config"]
            if layer["class_name"] == "Dense":
                got.append(("Dense", conf["name"], conf["units"], conf["activation"], conf.get("use_bias", True)))
            elif layer["class_name"] == "Lambda":
                code = base64.b64decode(conf["function"][0]) if conf.get("function_type") == "lambda" else b""
                got.append(("Lambda", "exp(x) - 1" if b"exp" in code else "not exp(x) - 1"))
            else:
                got.append((layer["class_name"],))
        inputs = layers[0]["config"].get("batch_input_shape", [None, None])[-1] if layers else None
    except (KeyError, IndexError, TypeError, AttributeError, binascii.Error) as e:
        raise ValueError(f"{path}: not a Keras Sequential model's JSON ({type(e).__name__} {e})") from None
    want = [("Dense", name, units, act, True) for name, _, units, act in LAYERS] + [("Lambda", "exp(x) - 1")]
    if model.get("class_name") != "Sequential" or inputs != 6 or got != want:
        raise ValueError(f"{path}: a {model.get('class_name')} of {inputs} inputs and layers {got}, not the NBRDF network (Sequential, 6 inputs, {want})")


def load(path):
    """The network of NAME.h5 (NAME.json beside it is checked first): Net(path, ((kernel, bias) float64) x 3). A missing
    file, a JSON that is not LAYERS, a missing dataset, a wrong shape or a NaN weight: a one-line ValueError."""
    path = Path(path)
    arch = path.with_suffix(".json")
    for p in (path, arch):
        if not p.is_file():
            raise ValueError(f"{p}: no such file")
    check_architecture(arch)
    layers = []
    try:
        with h5py.File(path, "r") as f:
            for name, n_in, n_out, _ in LAYERS:
                pair = []
                for what, shape in (("kernel:0", (n_in, n_out)), ("bias:0", (n_out,))):
                    key = f"{name}/{name}/{what}"
                    data = f.get(key)
                    if not isinstance(data, h5py.Dataset):
                        raise ValueError(f"{path}: no dataset {key}")
                    if data.shape != shape or data.dtype.kind != "f":
                        raise ValueError(f"{path}: {key} is {data.dtype} {data.shape}, not float {shape}")
                    values = np.asarray(data[()], dtype=np.float64)  # float32 -> float64: exact
                    if not np.isfinite(values).all():
                        raise ValueError(f"{path}: {key} holds a NaN or an infinity")
                    pair.append(values)
                layers.append(tuple(pair))
    except OSError as e:  # h5py's: not HDF5, truncated, unreadable
        raise ValueError(f"{path}: not readable as HDF5 ({str(e).splitlines()[0]})") from None
    return Net(path, tuple(layers))


def inputs(theta_h, theta_d, phi_d):
    """The network's input [n, 6] (the authors' rangles_to_rvectors): (sin theta_h, 0, cos theta_h, sin theta_d cos phi_d,
    sin theta_d sin phi_d, cos theta_d), the angles broadcast together and flattened."""
    th, td, pd = (a.ravel() for a in np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (theta_h, theta_d, phi_d))))
    return np.stack([np.sin(th), np.zeros_like(th), np.cos(th), np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], 1)


def evaluate(net, theta_h, theta_d, phi_d):
    """rho [n, 3] = exp(y) - 1 of the network at the Rusinkiewicz angles (phi_h = 0), float64, as the network gives it
    (negative where y < 0)."""
    x = inputs(theta_h, theta_d, phi_d)
    out = np.empty((len(x), 3))
    for lo in range(0, len(x), CHUNK):
        y = x[lo : lo + CHUNK]
        for n, (kernel, bias) in enumerate(net.layers):
            y = y @ kernel + bias
            if n < len(net.layers) - 1:
                np.maximum(y, 0.0, out=y)  # ReLU
        out[lo : lo + CHUNK] = np.expm1(y)
    return out


def to_merl(net):
    """rho [3, 90, 90, 180] in merl.py's convention, for merl.write: NaN at the bins merl.directions() does not count
    valid (wi_z or wo_z below 1e-6: written -1, below the horizon), max(exp(y) - 1, 0) elsewhere (module docstring).
    An infinite rho (exp overflowing) is a ValueError: MERL readers (merl.rs) refuse the file."""
    theta_h, theta_d, phi_d = merl.angles()
    valid = merl.directions()[2]
    i, j, k = np.nonzero(valid)
    rho = evaluate(net, theta_h[i], theta_d[j], phi_d[k])
    if not np.isfinite(rho).all():
        n = int(np.argmax(~np.isfinite(rho).all(1)))
        raise ValueError(f"{net.path}: rho {rho[n].tolist()} at bin ({i[n]}, {j[n]}, {k[n]})")
    out = np.full((3,) + merl.DIMS, np.nan)
    out[:, valid] = np.maximum(rho, 0.0).T
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="nbrdf", description="Write the MERL file (DIR/NAME.binary) of each NBRDF network NAME.h5 (Sztrajman et al. 2021; "
                                 "NAME.json beside it, its architecture), evaluated at MERL's bins.")
    ap.add_argument("h5", nargs="+", type=Path, help="NAME.h5: the network's Keras weights")
    ap.add_argument("--out", type=Path, required=True, help="the folder the files go to (made if missing)")
    args = ap.parse_args(argv)
    written = []
    try:
        names = [p.stem for p in args.h5]
        if len(set(names)) < len(names):
            raise ValueError(f"two inputs named {next(n for n in names if names.count(n) > 1)}: their files would collide")
        if args.out.exists() and not args.out.is_dir():
            raise ValueError(f"{args.out}: not a directory")
        nets = [load(p) for p in args.h5]  # every input checked before anything is written
        args.out.mkdir(parents=True, exist_ok=True)
        for name, net in zip(names, nets):
            start = time.perf_counter()
            rho = to_merl(net)
            tmp = args.out / f".{name}.binary.{os.getpid()}.part"
            written.append(tmp)
            merl.write(tmp, rho)
            print(f"{args.out / name}.binary: {int(np.isfinite(rho[0]).sum())} valid bins, {int((rho == 0).sum())} values 0 "
                  f"(exp(y) - 1 < 0), {time.perf_counter() - start:.1f} s", file=sys.stderr)
        for name, tmp in zip(names, written):
            os.replace(tmp, args.out / f"{name}.binary")
    except (ValueError, OSError) as e:
        for tmp in written:
            tmp.unlink(missing_ok=True)
        print(f"nbrdf: error: {e}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
