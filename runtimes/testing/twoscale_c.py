"""ctypes driver of the C reference BRDF runtimes/c/twoscale_brdf.h (docs/runtimes.md).

    from twoscale_c import CBrdf
    brdf = CBrdf("tables-out/scene-materials/nickel", lobe="exact")   # energy="single" (default) or "compensated"
    rho = brdf.eval(wi, wo, lam)                   # wi, wo [n, 3] unit vectors, lam [n] micrometres; no cosine
    rho = brdf.eval(wi, wo, lam, eta=eta, k=k)     # conductor Fresnel (eta, k [n]); default F = 1
    spec, diff = brdf.eval_parts(wi, wo, lam)      # rho's two parts with F = 1
    pdf = brdf.pdf(wi, wo, lam)                    # lam: the hero wavelength
    wo, pdf, weight = brdf.sample(wi, lam, xi1, xi2)   # weight = rho cos theta_o / pdf

The material folder is exported (`twoscale export --format c-header --dir FOLDER`) and compiled with a
small shim (cc -std=c99 -O2 -shared -fPIC -Wall -Wextra -Werror) into cache_dir, under a key of the
exported headers, the C sources and the flags: a folder is compiled once. Arguments broadcast like
numpy's; every loop runs in C, in double.
"""
import ctypes
import fcntl
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
# The C reader's header (twoscale_tables.h) and the BRDF's (twoscale_brdf.h).
C_HEADERS = [REPO / "pipeline/tables/c/twoscale_tables.h", REPO / "runtimes/c/twoscale_brdf.h"]
C_INCLUDES = [a for h in C_HEADERS for a in ("-I", str(h.parent))]
CFLAGS = ["-std=c99", "-O2", "-shared", "-fPIC", "-Wall", "-Wextra", "-Werror"]

# One twoscale_brdf per (lobe, energy) choice, index lobe + 2 energy (lobe 0 exact, 1 fit; energy 0
# single, 1 compensated); every function loops over n points.
SHIM = r"""
#include MATERIAL_HEADER

static twoscale_brdf brdf[4];

const char *shim_init(int lobe) {
    return twoscale_brdf_init(&brdf[lobe], &MATERIAL, lobe % 2 ? TWOSCALE_LOBE_FIT : TWOSCALE_LOBE_EXACT,
                              lobe / 2 ? TWOSCALE_ENERGY_COMPENSATED : TWOSCALE_ENERGY_SINGLE);
}

static twoscale_fresnel shim_fresnel(const double *eta, const double *k, long i) {
    return eta ? twoscale_fresnel_conductor(eta[i], k[i]) : twoscale_fresnel_one();
}

void shim_eval(int lobe, long n, const double *wi, const double *wo, const double *lam, const double *eta, const double *k, double *out) {
    long i;
    for (i = 0; i < n; i++) out[i] = twoscale_brdf_eval(&brdf[lobe], wi + 3 * i, wo + 3 * i, lam[i], shim_fresnel(eta, k, i));
}

void shim_eval_parts(int lobe, long n, const double *wi, const double *wo, const double *lam, double *parts) {
    long i;
    for (i = 0; i < n; i++) twoscale_brdf_eval_parts(&brdf[lobe], wi + 3 * i, wo + 3 * i, lam[i], parts + 2 * i);
}

void shim_pdf(int lobe, long n, const double *wi, const double *wo, const double *lam, double *out) {
    long i;
    for (i = 0; i < n; i++) out[i] = twoscale_brdf_pdf(&brdf[lobe], wi + 3 * i, wo + 3 * i, lam[i]);
}

void shim_sample(int lobe, long n, const double *wi, const double *lam, const double *xi1, const double *xi2, const double *eta,
                 const double *k, double *wo, double *pdf, double *weight) {
    long i;
    for (i = 0; i < n; i++)
        weight[i] = twoscale_brdf_sample(&brdf[lobe], wi + 3 * i, lam[i], xi1[i], xi2[i], shim_fresnel(eta, k, i), wo + 3 * i, pdf + i);
}
"""

_D = ctypes.POINTER(ctypes.c_double)
_LOBES = {"exact": 0, "fit": 1}
_ENERGIES = {"single": 0, "compensated": 2}


def twoscale_binary():
    """$TWOSCALE_BIN, else this repository's release build."""
    return os.environ.get("TWOSCALE_BIN") or str(REPO / "target/release/twoscale")


def minisign(*args, cwd=None):
    """Debian's minisign (the reference the signature tests hold twoscale's readers to) with these arguments, which
    must succeed; no terminal, so it never waits for a password."""
    if shutil.which("minisign") is None:
        raise AssertionError("minisign is missing (`make deps` installs Debian's)")
    args = [str(a) for a in args]
    res = subprocess.run(["minisign", *args], cwd=cwd, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, f"minisign {' '.join(args)}: {res.stderr.strip()}"


# compile_material's libraries by what this process saw of their folder.
_COMPILED = {}


def compile_material(folder, cache_dir, twoscale=None, cc="cc"):
    """The shared library of the material folder's BRDF in cache_dir (built when missing). Known to this process
    by the folder's files (name, size, mtime) it costs nothing; else the folder is exported to find the library's
    key (0.2-0.3 s for a diffracting material, which the tests used to pay at every CBrdf they made)."""
    folder = Path(folder).resolve()
    seen = (folder, Path(cache_dir).resolve(), twoscale, cc,
            tuple((f.name, s.st_size, s.st_mtime_ns) for f in sorted(folder.iterdir()) for s in [f.stat()]))
    if seen not in _COMPILED or not _COMPILED[seen].exists():
        _COMPILED[seen] = _compile_material(folder, cache_dir, twoscale, cc)
    return _COMPILED[seen]


def _compile_material(folder, cache_dir, twoscale, cc):
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache_dir) as tmp:
        out = subprocess.run([twoscale or twoscale_binary(), "export", "--quiet", "--format", "c-header", "--dir", str(folder), "--out", tmp],
                             capture_output=True, text=True)
        if out.returncode != 0:
            raise RuntimeError(out.stderr.strip() or f"twoscale export failed on {folder}")
        headers = sorted(Path(tmp).glob("*.h"))
        material = next(h for h in headers if h.name.startswith("twoscale_material_"))
        key = hashlib.sha256()
        for f in headers + C_HEADERS:
            key.update(f.name.encode() + b"\0" + f.read_bytes())
        key.update(SHIM.encode() + " ".join([cc] + CFLAGS).encode())
        lib = cache_dir / f"{material.stem}-{key.hexdigest()[:16]}.so"
        # One compiler per key: make test runs the Mitsuba and the C tests side by side on one cache, and they
        # reach the same materials (3-8 s of gcc each); the second waits for the first's library.
        with open(lib.with_suffix(".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if lib.exists():
                return lib
            shim = Path(tmp) / "shim.c"
            shim.write_text(SHIM)
            part = Path(tmp) / lib.name
            cmd = [cc, *CFLAGS, f"-DMATERIAL_HEADER=\"{material.name}\"", f"-DMATERIAL={material.stem}", *C_INCLUDES, "-I", tmp,
                   str(shim), "-o", str(part), "-lm"]
            res = subprocess.run(cmd, capture_output=True, text=True)
            if res.returncode != 0:
                raise RuntimeError(f"{' '.join(cmd)}:\n{res.stderr}")
            shutil.move(part, lib)  # complete or absent
            return lib


class CBrdf:
    """The C reference BRDF of one material folder (see the module's docstring)."""

    def __init__(self, folder, lobe="exact", cache_dir=None, twoscale=None, energy="single"):
        if lobe not in _LOBES or energy not in _ENERGIES:
            raise ValueError(f"lobe {lobe!r}, energy {energy!r}: exact or fit, single or compensated")
        self.lobe = _LOBES[lobe] + _ENERGIES[energy]
        cache_dir = cache_dir or Path(tempfile.gettempdir()) / "twoscale-c-brdf"
        self.lib = ctypes.CDLL(str(compile_material(folder, cache_dir, twoscale)))
        self.lib.shim_init.restype = ctypes.c_char_p
        err = self.lib.shim_init(self.lobe)
        if err:
            raise ValueError(f"{folder}: {err.decode()}")

    @staticmethod
    def _arrays(vectors, scalars):
        """Broadcast vectors ([n, 3] or [3]) and scalars ([n] or scalar; None stays None) to n points,
        C-contiguous float64: (n, vectors, scalars)."""
        vectors = [np.asarray(v, np.float64) for v in vectors]
        scalars = [None if s is None else np.asarray(s, np.float64) for s in scalars]
        shape = np.broadcast_shapes(*[v.shape[:-1] for v in vectors], *[s.shape for s in scalars if s is not None])
        n = int(np.prod(shape))
        vectors = [np.ascontiguousarray(np.broadcast_to(v, shape + (3,)).reshape(n, 3)) for v in vectors]
        scalars = [None if s is None else np.ascontiguousarray(np.broadcast_to(s, shape).reshape(n)) for s in scalars]
        return n, vectors, scalars

    @staticmethod
    def _p(a):
        return None if a is None else a.ctypes.data_as(_D)

    def eval(self, wi, wo, lam, eta=None, k=None):
        """rho(wi, wo) at lam (micrometres), without the cosine; F = 1 unless eta, k are given."""
        n, (wi, wo), (lam, eta, k) = self._arrays((wi, wo), (lam, eta, k))
        out = np.empty(n)
        self.lib.shim_eval(self.lobe, ctypes.c_long(n), *map(self._p, (wi, wo, lam, eta, k, out)))
        return out

    def eval_parts(self, wi, wo, lam):
        """(specular, diffraction): rho's two parts with F = 1."""
        n, (wi, wo), (lam,) = self._arrays((wi, wo), (lam,))
        parts = np.empty((n, 2))
        self.lib.shim_eval_parts(self.lobe, ctypes.c_long(n), *map(self._p, (wi, wo, lam, parts)))
        return parts[:, 0], parts[:, 1]

    def pdf(self, wi, wo, lam):
        """The density in solid angle of wo that sample() realises at the hero wavelength lam."""
        n, (wi, wo), (lam,) = self._arrays((wi, wo), (lam,))
        out = np.empty(n)
        self.lib.shim_pdf(self.lobe, ctypes.c_long(n), *map(self._p, (wi, wo, lam, out)))
        return out

    def sample(self, wi, lam, xi1, xi2, eta=None, k=None):
        """(wo [n, 3], pdf [n], weight [n] = rho cos theta_o / pdf); a lost sample has pdf 0, weight 0."""
        n, (wi,), (lam, xi1, xi2, eta, k) = self._arrays((wi,), (lam, xi1, xi2, eta, k))
        wo, pdf, weight = np.empty((n, 3)), np.empty(n), np.empty(n)
        self.lib.shim_sample(self.lobe, ctypes.c_long(n), *map(self._p, (wi, lam, xi1, xi2, eta, k, wo, pdf, weight)))
        return wo, pdf, weight
