"""Mitsuba 3 BSDF plugin `twoscale`: the two-scale BRDF of docs/maths.md section 7 from twoscale tables.

    import mitsuba as mi; mi.set_variant("llvm_ad_spectral")   # or scalar_spectral
    import twoscale_bsdf; twoscale_bsdf.register()
    bsdf = mi.load_dict({"type": "twoscale", "tables": "tables-out/default",   # preset dir or bundle .tar.gz
                         "beta": 0.1, "p": 0.9, "sigma_s": 0.004, "b": 0.8, "c": 2.3,
                         "lobe": "fit",                     # or "exact" (table zh_lobe)
                         "eta": {"type": "spectrum", "value": [(400, 1.6), (700, 2.1)]},
                         "k": {"type": "spectrum", "value": [(400, 2.6), (700, 3.9)]}})

Parameters: tables, beta, p, sigma_s and b (micrometres), c, lobe ("fit" | "exact"),
fit_variant ("cos" | "plain", the fitted lobe of zh_convolution used by lobe = "fit"),
eta and k (the conductor's complex index: floats or spectra), or fresnel = "one" for F = 1
(white furnace). One-sided (front side), glossy reflection. The sampling strategy and its
mixture weights are documented in twoscale_model.py. Each call converts Dr.Jit arrays to numpy
and back, so JIT variants need evaluated (non-symbolic) loops and calls: `jit_wavefront()` below sets them.
"""
import drjit as dr
import mitsuba as mi
import numpy as np

from twoscale_model import TwoScaleError, TwoScaleModel, open_tables

_CACHE = {}  # tables opened (and verified) once per process, by path and the set needed


def _np(x):
    return np.atleast_1d(np.asarray(x, dtype=np.float64))


def _vec(v, n):
    return np.stack([np.broadcast_to(_np(v[j]), (n,)) for j in range(3)], axis=1)


def _make_class():
    """The plugin class, derived from the BSDF base of the variant set now (each variant has its own)."""

    class TwoScaleBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if not mi.is_spectral or mi.is_polarized:
                raise TwoScaleError(f"twoscale: needs an unpolarised spectral variant (not {mi.variant()})")

            def get(name, default=None):
                if name in props:
                    return props[name]
                if default is None:
                    raise TwoScaleError(f"twoscale: parameter {name!r} is missing")
                return default

            path = str(get("tables"))
            params = {n: float(get(n, d)) for n, d in (("beta", None), ("p", None), ("sigma_s", 0.0))}
            # b and c shape the diffraction part: required with it, unused without it.
            for n in ("b", "c"):
                params[n] = float(get(n) if params["sigma_s"] > 0 else get(n, 1.0 if n == "b" else 2.0))
            lobe, variant = str(get("lobe", "fit")), str(get("fit_variant", "cos"))
            names = ["epd_g1", "epd_norm"] + (["kcorr_renorm", "zh_convolution"] if params["sigma_s"] > 0 else [])
            names += ["zh_lobe"] if lobe == "exact" and params["sigma_s"] > 0 else []
            key = (path, tuple(names))
            if key not in _CACHE:
                _CACHE[key] = open_tables(path, names)
            self.model = TwoScaleModel(_CACHE[key], lobe=lobe, fit_variant=variant, **params)
            fresnel = str(get("fresnel", "conductor"))
            if fresnel not in ("conductor", "one"):
                raise TwoScaleError(f'twoscale: fresnel = {fresnel!r}: expected "conductor" or "one"')
            self.eta = self.k = None
            if fresnel == "conductor":
                for name in ("eta", "k"):
                    if name not in props:
                        raise TwoScaleError(f'twoscale: parameter {name!r} is missing (or set fresnel = "one")')
                self.eta, self.k = props.get_unbounded_texture("eta"), props.get_unbounded_texture("k")
            self.m_components = [mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide]
            self.m_flags = self.m_components[0]

        # -- conversions between Dr.Jit and numpy ---------------------------------
        def _inputs(self, si, wo, active):
            n = max(dr.width(si.wi), dr.width(active), 1 if wo is None else dr.width(wo))
            wi = _vec(si.wi, n)
            lam = [np.broadcast_to(_np(si.wavelengths[j]), (n,)) * 1e-3 for j in range(len(si.wavelengths))]
            mask = np.broadcast_to(np.asarray(active, dtype=bool).reshape(-1), (n,)) & np.all(np.isfinite(wi), axis=1)
            mask = mask & (lam[0] >= 0.36 - 1e-9) & (lam[0] <= 0.83 + 1e-9)
            return n, wi, (None if wo is None else _vec(wo, n)), lam, mask

        def _conductor(self, si, active, n):
            if self.eta is None:
                return None, None
            out = []
            for param in (self.eta, self.k):
                v = param.eval(si, active)
                out.append([np.broadcast_to(_np(v[j]), (n,)) for j in range(len(si.wavelengths))])
            return out

        @staticmethod
        def _float(a):
            return mi.Float(a) if dr.is_jit_v(mi.Float) else float(a[0])

        def _spectrum(self, chans):
            return mi.UnpolarizedSpectrum(*[self._float(c) for c in chans])

        def _eval_np(self, si, wi, wo, lam, mask, active, n):
            """rho cos_o per wavelength channel (numpy), 0 outside mask."""
            eta, k = self._conductor(si, active, n)
            chans = []
            for j, lj in enumerate(lam):
                if j > 0 and np.array_equal(lj, lam[0]):
                    chans.append(chans[0])  # the same wavelength (a monochromatic query)
                    continue
                v = np.zeros(n)
                if mask.any():
                    e = None if eta is None else eta[j][mask]
                    kk = None if k is None else k[j][mask]
                    v[mask] = self.model.eval(wi[mask], wo[mask], lj[mask], e, kk) * np.maximum(wo[mask, 2], 0.0)
                chans.append(v)
            return chans

        def _pdf_np(self, wi, wo, lam, mask, n):
            out = np.zeros(n)
            if mask.any():
                out[mask] = self.model.pdf(wi[mask], wo[mask], lam[0][mask])
            return out

        # -- the BSDF interface ----------------------------------------------------
        def _enabled(self, ctx):
            return ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0)

        def eval(self, ctx, si, wo, active=True):
            n, wi, wo_, lam, mask = self._inputs(si, wo, active)
            if not self._enabled(ctx):
                mask = np.zeros(n, dtype=bool)
            return self._spectrum(self._eval_np(si, wi, wo_, lam, mask, active, n))

        def pdf(self, ctx, si, wo, active=True):
            n, wi, wo_, lam, mask = self._inputs(si, wo, active)
            if not self._enabled(ctx):
                mask = np.zeros(n, dtype=bool)
            return self._float(self._pdf_np(wi, wo_, lam, mask, n))

        def eval_pdf(self, ctx, si, wo, active=True):
            n, wi, wo_, lam, mask = self._inputs(si, wo, active)
            if not self._enabled(ctx):
                mask = np.zeros(n, dtype=bool)
            return (self._spectrum(self._eval_np(si, wi, wo_, lam, mask, active, n)),
                    self._float(self._pdf_np(wi, wo_, lam, mask, n)))

        def sample(self, ctx, si, sample1, sample2, active=True):
            n, wi, _, lam, mask = self._inputs(si, None, active)
            n = max(n, dr.width(sample1), dr.width(sample2))
            wi, lam = np.broadcast_to(wi, (n, 3)), [np.broadcast_to(lj, (n,)) for lj in lam]
            mask = np.broadcast_to(mask, (n,)) & (wi[:, 2] > 0)
            if not self._enabled(ctx):
                mask = np.zeros(n, dtype=bool)
            xi0 = np.broadcast_to(_np(sample1), (n,))
            xi1, xi2 = np.broadcast_to(_np(sample2[0]), (n,)), np.broadcast_to(_np(sample2[1]), (n,))
            wo = np.zeros((n, 3))
            lam0 = np.where(mask, lam[0], 0.55)
            if mask.any():
                wo[mask] = self.model.sample(wi[mask], xi0[mask], xi1[mask], xi2[mask], lam0[mask])
            mask = mask & (wo[:, 2] > 0)
            pdf = self._pdf_np(wi, wo, lam, mask, n)
            mask = mask & (pdf > 0)
            vals = self._eval_np(si, wi, wo, lam, mask, active, n)
            weights = [np.where(mask, v / np.where(mask, pdf, 1.0), 0.0) for v in vals]
            bs = dr.zeros(mi.BSDFSample3f, n) if dr.is_jit_v(mi.Float) else mi.BSDFSample3f()
            bs.wo = mi.Vector3f(*[self._float(wo[:, j]) for j in range(3)])
            bs.pdf = self._float(np.where(mask, pdf, 0.0))
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            return bs, self._spectrum(weights)

        def to_string(self):
            m = self.model
            return (f"TwoScaleBSDF[beta={m.beta}, p={m.p}, sigma_s={m.sigma_s}, b={m.b}, c={m.c}, "
                    f"lobe={m.lobe}, fit_variant={m.fit_variant}]")

    return TwoScaleBSDF


_CLASSES = {}  # variant -> plugin class


def register():
    """Registers `twoscale` for the current variant (call again after switching variants)."""
    if mi.variant() not in _CLASSES:
        _CLASSES[mi.variant()] = _make_class()
    cls = _CLASSES[mi.variant()]
    mi.register_bsdf("twoscale", lambda props: cls(props))


def jit_wavefront():
    """JIT variants: record no loops or calls symbolically, so that the plugin sees real arrays."""
    if dr.is_jit_v(mi.Float):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
