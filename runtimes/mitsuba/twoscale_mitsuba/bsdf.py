"""Mitsuba 3 BSDF `twoscale`: the two-scale BRDF of docs/maths.md section 7 on one material's tables.

    import mitsuba as mi; mi.set_variant("llvm_ad_spectral")   # any unpolarised spectral variant
    import twoscale_mitsuba   # registers the plugin (for this variant and any set later)
    bsdf = mi.load_dict({"type": "twoscale",
                         "tables": "tables-out/scene-materials/nickel",   # a material folder, or its bundle
                         "eta": {"type": "spectrum", "value": [(400, 1.6), (700, 2.1)]},
                         "k": {"type": "spectrum", "value": [(400, 2.6), (700, 3.9)]}})

Parameters:
- tables: a material folder of `twoscale build --scene` (docs/material_tables.md), or a bundle
  (.tar.gz) of one; a bundle of several materials needs `material` (the folder's name).
  Checksums are verified on load.
- public_key: a minisign public key (a `.pub` file's path or its base64 line) that signed the bundle
  `tables`: BUNDLE.tar.gz.minisig is verified before the bundle is read, and a bundle without one is
  refused (docs/file_contract.md "Signatures"). Only with a bundle; without it, no signature is checked.
- eta, k: the conductor's complex index (floats or spectra); or fresnel = "one" for F = 1. A plastic or
  subsurface material (docs/maths.md sections 10, 11: the folder's `model`) takes its interface's index
  and its layer from the folder, and neither.
- lobe: "exact" (zh_lobe, the default) or "fit" (zh_convolution's fitted cos lobe, the paper's way).
- energy: "single" (the default: the paper's single-scattering BRDF) or "compensated" (reciprocal,
  energy-conserving: the folder's `albedo` tables; docs/runtimes.md "Energy compensation").
- beta, p, sigma_s, b, c: read from the folder's manifests; when given, they must match.

Everything per call is Dr.Jit: tables are `mi.Texture1f` / `mi.Texture2f` (linear, clamped) over
their encoded coordinates, so the BSDF runs in symbolic (megakernel) and evaluated modes, in JIT and
scalar variants, and is differentiable in sigma_s, b, eta and k (`mi.traverse`; a plastic or subsurface
material: sigma_s, b and a constant `diffuse` or `albedo`; the dipole's R_d has an infinite slope in
`albedo` at 1). What it computes,
the sampling mixture and its exact pdf: docs/runtimes.md.
"""
import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
from twoscale_tables import Table  # the reader package, pipeline/tables/python (`make pyenv`)

from .general import GeneralTables, is_preset
from .lookup import LAMBDA_RANGE, TwoScaleError, bounded_log_tan, buffer, encode, lobe_angle, opaque, quantile_density, table_folder

W_MIN = 0.1  # smallest share of either sampling strategy (docs/runtimes.md)
W_MS_MAX = 0.9  # largest share of the multiple-scattering lobe's cosine sampling
# F_avg = 2 int_0^1 F(mu) mu dmu by 8-point Gauss-Legendre (error < 1e-5 for k >= 1, 5e-5 for k >= 0.3)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
# Python floats: a numpy scalar times a Dr.Jit array converts the array, scheduling a kernel (refused in a symbolic render).
FAVG_NODES = [(float(0.5 * (x + 1.0)), float(0.5 * w)) for x, w in zip(_GL_X, _GL_W)]
MATERIAL_PARAMS = ("beta", "p", "sigma_s", "b", "c")


# -- loading a material folder ------------------------------------------------------------------
def _material_dirs(root):
    return sorted(d.parent for d in Path(root).rglob("epd_g1.manifest.json"))


def load_material(folder, material=None, energy=False, bundle=None):
    """(params, {table: Table}) of a material folder, or of the folder the bundle `bundle` unpacked to (one of
    several materials picked by `material`), every checksum verified; with `energy`, the albedo table as well."""
    folder = Path(folder)
    if bundle is not None:
        dirs = _material_dirs(folder)
        if material is not None:
            dirs = [d for d in dirs if d.name == material]
        if len(dirs) != 1:
            names = ", ".join(d.name for d in _material_dirs(folder)) or "none"
            what = f"no material {material!r}" if material is not None else "several materials: set `material`"
            raise TwoScaleError(f"{bundle}: {what} (it holds: {names})")
        return _open_folder(dirs[0], f"{bundle}: ", energy)
    if not (folder / "epd_g1.manifest.json").exists():
        raise TwoScaleError(f"{folder}: not a material folder (no epd_g1.manifest.json; build one with `twoscale build --scene`)")
    return _open_folder(folder, "", energy)


def _open_folder(folder, origin, energy):
    def open_table(name):
        h5 = folder / f"{name}.h5"
        if not h5.exists():
            raise TwoScaleError(f"{origin}{folder}: table {name} is missing")
        try:
            return Table.open(h5)
        except ValueError as e:  # the reader's message names the file and the dataset
            raise TwoScaleError(f"{origin}{e}") from None
        except (OSError, KeyError) as e:
            raise TwoScaleError(f"{origin}{h5}: unreadable table ({e})") from None

    tables = {"epd_g1": open_table("epd_g1")}
    params = tables["epd_g1"].manifest.get("material")
    if params is None:
        raise TwoScaleError(f"{origin}{folder}: epd_g1 has no `material` section: not a material folder")
    needed = ["epd_sampling"]
    if (params.get("sigma_s") or 0.0) > 0.0:
        needed += ["kcorr_renorm", "zh_lobe", "zh_lobe_sampling", "zh_convolution"]
    if energy:
        needed += ["albedo"]
    model = params.get("model", "conductor")
    if model in ("plastic", "subsurface"):
        needed += ["interface_albedo"]
    elif model != "conductor":
        raise TwoScaleError(f"{origin}{folder}: material model {model!r} is not one this BSDF renders (conductor, plastic, subsurface)")
    for name in needed:
        tables[name] = open_table(name)
        if tables[name].manifest.get("material") != params:
            raise TwoScaleError(f"{origin}{folder}/{name}.manifest.json: its material differs from epd_g1's")
    return params, tables


# -- tables as textures -------------------------------------------------------------------------
class _Axis:
    """A uniform encoded axis: the texture coordinate of e is (e - e0) / (e1 - e0) (n - 1)/n + 1/(2n),
    which puts node k at texel centre k (linear filtering interpolates between nodes)."""

    def __init__(self, table, i, kind):
        a = table.manifest["axes"][i]
        if a["encoding"]["kind"] != kind or not a.get("uniform"):
            raise TwoScaleError(f"{table.manifest['table']}: axis {a['name']} is not uniform in the encoding {kind} "
                                "(docs/material_tables.md): not a per-material table of this version")
        e = table.encoded[i]
        self.enc = {k: (v if k == "kind" else opaque(v)) for k, v in a["encoding"].items()}
        self.n = a["size"]
        step = float(e[-1] - e[0]) / (self.n - 1)
        self.e0, self.step = opaque(e[0]), opaque(step)
        self.scale, self.offset = opaque(1.0 / (step * self.n)), opaque(0.5 / self.n)

    def pos(self, e):
        return dr.fma(e - self.e0, self.scale, self.offset)

    def at(self, x):
        return self.pos(encode(self.enc, x))


def _texture(table, names):
    data = np.stack([table.values[n] for n in names], axis=-1).astype(np.float32)
    tex = {1: mi.Texture1f, 2: mi.Texture2f}[data.ndim - 1]
    return tex(mi.TensorXf(data), use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)


class _Albedo:
    """An albedo table over theta_i, and lambda where the material diffracts, as one texture: the folder's
    `albedo` (g, e_comp, e_comp_avg: docs/runtimes.md "Energy compensation"), or a plastic's or subsurface
    material's `interface_albedo` (e_f, e_f_avg, or e_fc, e_fc_avg: docs/maths.md section 10)."""

    def __init__(self, table, names=("g", "e_comp", "e_comp_avg")):
        self.theta = _Axis(table, 0, "bounded_log_tan")
        self.lam = _Axis(table, 1, "log") if len(table.axes) == 2 else None
        self.tex = _texture(table, list(names))

    def at(self, sin_t, cos_t, lam):
        """The values at the angle of sine sin_t and cosine cos_t, and lam (micrometres)."""
        x = self.theta.pos(bounded_log_tan(self.theta.enc, sin_t, cos_t))
        return self.tex.eval(mi.Point1f(x) if self.lam is None else mi.Point2f(self.lam.at(lam), x))

    def avg(self, lam):
        """The last value (an average) at lam, read at theta = 0 (it does not depend on theta; one point keeps
        rho(i, o) = rho(o, i) exact)."""
        return self.at(mi.Float(0.0), mi.Float(1.0), lam)[-1]


# -- the pieces of docs/maths.md section 7 ------------------------------------------------------
def _fresnel(cos_d, eta, k):
    return mi.fresnel_conductor(cos_d, mi.Complex2f(eta, k))


def _dielectric(cos_d, eta):
    """The unpolarised reflectance of a smooth dielectric of index eta (a plastic's or subsurface material's interface)."""
    return mi.fresnel(cos_d, eta)[0]


def _fresnel_avg(fresnel):
    """F_avg = 2 int_0^1 F(mu) mu dmu (Kulla and Conty's average Fresnel) of fresnel(mu)."""
    return sum(2.0 * w * mu * fresnel(mi.Float(mu)) for mu, w in FAVG_NODES)


def _ms_factor(e_avg, f_avg):
    """The multiple-scattering lobe's Fresnel factor F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg))."""
    return f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg))


def _piecewise_linear(xs, ys, x):
    """ys at x, linear between the samples xs (increasing), clamped: a few selects (a diffuse spectrum)."""
    y = opaque(ys[0]) + 0.0 * x
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        y = dr.select(x > x0, opaque(y0) + (x - x0) * opaque((y1 - y0) / (x1 - x0)), y)
    return dr.select(x >= xs[-1], opaque(ys[-1]), y)


def _parameter(props, name, domain, where):
    """A general-mode parameter as a texture (read with eval_1). A float, or a bitmap, outside `domain` is refused;
    any other texture is read clamped to it (BSDF._material). A bitmap holds numbers: one channel, "raw": True."""
    lo, hi = domain
    span = f"[{lo:g}, {hi:g}]"
    value = props.get(name)
    if isinstance(value, (int, float)):
        if not lo <= float(value) <= hi:
            raise TwoScaleError(f"twoscale: {name} = {float(value):g} is outside the tables' domain {span} ({where})")
        return props.get_unbounded_texture(name)
    tex = props.get_unbounded_texture(name)
    if tex.class_name().startswith("BitmapTexture"):
        data = np.asarray(mi.traverse(tex)["data"])
        if "raw = 1" not in str(tex) or data.shape[-1] != 1:
            raise TwoScaleError(f"twoscale: {name}'s bitmap must be one channel, read raw (\"raw\": True): it holds {name} itself")
        if not (lo <= float(data.min()) and float(data.max()) <= hi):
            raise TwoScaleError(f"twoscale: {name}'s bitmap holds {float(data.min()):g} to {float(data.max()):g}, outside the tables' "
                                f"domain {span} ({where})")
    return tex


def _theta(cos_t, sin_t):
    return dr.atan2(sin_t, cos_t)  # accurate near the normal, unlike acos in float32


def _make_class():
    """The plugin class, derived from the BSDF base of the variant set now (each variant has its own)."""

    class TwoScaleBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if not mi.is_spectral or mi.is_polarized:
                raise TwoScaleError(f"twoscale: needs an unpolarised spectral variant (not {mi.variant()})")
            if "tables" not in props:
                raise TwoScaleError("twoscale: parameter 'tables' is missing (a material folder or bundle)")
            self.energy = str(props["energy"]) if "energy" in props else "single"
            if self.energy not in ("single", "compensated"):
                raise TwoScaleError(f'twoscale: energy = {self.energy!r}: expected "single" or "compensated"')
            self.compensated = self.energy == "compensated"
            self.lobe = str(props["lobe"]) if "lobe" in props else "exact"
            if self.lobe not in ("exact", "fit"):
                raise TwoScaleError(f'twoscale: lobe = {self.lobe!r}: expected "exact" or "fit"')
            tables = str(props["tables"])
            public_key = str(props["public_key"]) if "public_key" in props else None
            self.general = None
            with table_folder(tables, public_key) as (folder, bundle):  # a bundle's tables are read into memory here
                if is_preset(folder):
                    self._init_general(props, tables, folder, bundle)
                else:
                    self._init_material(props, tables, folder, bundle)
            fresnel = str(props["fresnel"]) if "fresnel" in props else ("dielectric" if self.plastic else "conductor")
            if fresnel not in (("dielectric",) if self.plastic else ("conductor", "one")):
                raise TwoScaleError(f'twoscale: fresnel = {fresnel!r}: a plastic\'s or subsurface material\'s is its interface\'s ("dielectric"), '
                                    'a conductor\'s "conductor" or "one"')
            self.eta = self.k = None
            if fresnel == "conductor":
                for name in ("eta", "k"):
                    if name not in props:
                        raise TwoScaleError(f'twoscale: parameter {name!r} is missing (or set fresnel = "one")')
                self.eta, self.k = props.get_unbounded_texture("eta"), props.get_unbounded_texture("k")
            self.m_components = [mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide]
            self.m_flags = self.m_components[0]

        def _init_general(self, props, tables, folder, bundle):
            """General mode: the preset's tables, every parameter a float or a texture (docs/runtimes.md "General mode")."""
            self.general = GeneralTables(folder, self.lobe, self.compensated, bundle)
            self.name, self.folder, self.plastic, self.subsurface = "general", tables, False, False
            for name in MATERIAL_PARAMS:
                if name not in props:
                    raise TwoScaleError(f"twoscale: parameter {name!r} is missing: with a preset folder ({tables}) every one of "
                                        f"{', '.join(MATERIAL_PARAMS)} is required (a float or a texture)")
            if "material" in props:
                raise TwoScaleError(f"twoscale: 'material' names a folder of a scene build; {tables} is a preset folder")
            sigma_s = props.get("sigma_s")
            # A float sigma_s = 0 is a plain EPD surface everywhere: no diffraction tables are read, p may go down to epd_g1's 0.05.
            self.diffracts = not (isinstance(sigma_s, (int, float)) and float(sigma_s) == 0.0)
            dom = self.general.domain
            self.ranges = {name: dom["p_diffraction" if name == "p" and self.diffracts else name] for name in MATERIAL_PARAMS}
            self.params = {name: _parameter(props, name, self.ranges[name], tables) for name in MATERIAL_PARAMS}

        def _init_material(self, props, where, folder, bundle):
            """A material folder (or a bundle of them): every parameter from its manifests."""
            material = props["material"] if "material" in props else None
            params, t = load_material(folder, material, self.compensated, bundle)
            for name in MATERIAL_PARAMS:
                if name in props:
                    given = props.get(name)
                    if not isinstance(given, (int, float)):
                        raise TwoScaleError(f"twoscale: {name} is a texture, but {where} is a material folder, whose parameters are "
                                            "fixed: for parameters that vary over a surface give a preset folder (tables-out/default)")
                    stored = float(params.get(name) or 0.0)
                    if not math.isclose(float(given), stored, rel_tol=1e-6, abs_tol=1e-12):
                        raise TwoScaleError(f"twoscale: {name} = {float(given):g} differs from the tables' {stored:g} ({where})")
            self.name, self.folder = params["name"], where
            self.beta, self.p, self.n_p = opaque(params["beta"]), opaque(params["p"]), opaque(params["n_p"])
            self.diffracts = (params.get("sigma_s") or 0.0) > 0.0
            # Without diffraction b and c are absent (null); sigma_s = 0 keeps A = 1.
            self.sigma_s = opaque(params.get("sigma_s") or 0.0)
            self.b = opaque(params.get("b") or 1.0)
            self.c = opaque(params.get("c") or 2.0)
            self.wavelength_range = (params.get("wavelength_min"), params.get("wavelength_max"))

            self.g1_axis, self.g1 = _Axis(t["epd_g1"], 0, "bounded_log_tan"), _texture(t["epd_g1"], ["g1"])
            self.spec_axis, self.spec_q = _Axis(t["epd_sampling"], 0, "asin_sqrt"), _texture(t["epd_sampling"], ["theta_m"])
            self.spec_buf, self.spec_n = buffer(t["epd_sampling"].values["theta_m"]), t["epd_sampling"].axes[0].size
            if self.diffracts:
                kc = t["kcorr_renorm"]
                self.r_axes, self.ln_r = (_Axis(kc, 0, "log_gap"), _Axis(kc, 1, "log")), _texture(kc, ["r"])
                zl = t["zh_lobe"]
                self.lobe_u = _Axis(zl, 0, "log1p_sq")
                angle = zl.manifest["derived_axes"][0]
                if angle["kind"] != "material_lobe_angle":
                    raise TwoScaleError(f"{where}: zh_lobe's angle is not a material_lobe_angle: not a per-material table")
                self.lobe_angle = {k: opaque(angle[k]) for k in ("edge_d", "theta_cap", "v_anchor")}
                self.lobe_v = _Axis(zl, 1, "linear")
                self.ln_c = _texture(zl, ["c_lobe"])
                zc = t["zh_convolution"]
                self.fit_u, self.fit = _Axis(zc, 0, "shifted_log"), _texture(zc, ["s_cos", "g_cos"])
                zs = t["zh_lobe_sampling"]
                self.samp_u, self.samp_xi, self.samp_q = _Axis(zs, 0, "log1p_sq"), _Axis(zs, 1, "asin_sqrt"), _texture(zs, ["theta_h"])
                self.samp_buf, self.samp_n = buffer(zs.values["theta_h"]), zs.axes[1].size
            self.albedo = _Albedo(t["albedo"]) if self.compensated else None
            model = params.get("model", "conductor")
            self.plastic = model in ("plastic", "subsurface")  # a dielectric interface over a layer (either model)
            self.subsurface = model == "subsurface"
            if self.plastic:  # docs/maths.md sections 10 and 11
                self.ior = opaque(params["ior"])
                self.ior_sq = opaque(params["ior"] ** 2)
                # F_avg of the interface: a number (the index is fixed), computed once
                f_avg = _fresnel_avg(lambda mu: _dielectric(mu, mi.Float(params["ior"])))
                self.f_avg = opaque(float(np.ravel(np.asarray(f_avg))[0]) if dr.is_jit_v(mi.Float) else float(f_avg))
                names = ("e_fc", "e_fc_avg") if self.compensated else ("e_f", "e_f_avg")
                self.interface = _Albedo(t["interface_albedo"], names)
                # the layer's albedo: a plastic's diffuse d, a subsurface medium's reduced albedo alpha'; a constant
                # is a parameter (differentiable), a spectrum is read as written
                self.layer_key = "albedo" if self.subsurface else "diffuse"
                d = params[self.layer_key]
                self.diffuse = opaque(d) if isinstance(d, (int, float)) else (d["wavelengths"], d["values"])
                for name in ("eta", "k"):
                    if name in props:
                        raise TwoScaleError(f"twoscale: {name} is given, but a {model}'s Fresnel factor is its interface's (the folder's ior)")
                if self.subsurface:
                    self.phase_g, self.single_max = opaque(params["g"]), opaque(params["single_max"])
            lo, hi = self.wavelength_range
            if self.diffracts and (lo > LAMBDA_RANGE[0] + 1e-9 or hi < LAMBDA_RANGE[1] - 1e-9):
                mi.Log(mi.LogLevel.Warn, f"twoscale: {where} covers {lo:g}-{hi:g} um, Mitsuba samples "
                       f"{LAMBDA_RANGE[0]:g}-{LAMBDA_RANGE[1]:g} um: outside, the tables are read at their edge")

        # -- the parameters gradients flow to ---------------------------------------------------
        def traverse(self, callback):
            if self.general is not None:  # a float is a uniform texture ("beta.value"), a bitmap has "beta.data"
                for name, tex in self.params.items():
                    callback.put(name, tex, mi.ParamFlags.Differentiable)
            else:
                callback.put("sigma_s", self.sigma_s, mi.ParamFlags.Differentiable)
                callback.put("b", self.b, mi.ParamFlags.Differentiable)
            if self.plastic and not isinstance(self.diffuse, tuple):
                callback.put(self.layer_key, self.diffuse, mi.ParamFlags.Differentiable)
            if self.eta is not None:
                callback.put("eta", self.eta, mi.ParamFlags.Differentiable)
                callback.put("k", self.k, mi.ParamFlags.Differentiable)

        def parameters_changed(self, keys):
            pass  # every parameter is read per call

        # -- the material at an interaction ------------------------------------------------------
        def _material(self, si, active):
            """{beta, p, sigma_s, b, c, p_diff, n_p} at si: the folder's numbers, or in general mode the textures at si.uv,
            clamped to the tables' domain; p_diff is p clamped to the diffraction tables' (where sigma_s = 0 they are read,
            then multiplied by 1 - A = 0)."""
            if self.general is None:
                return {"beta": self.beta, "p": self.p, "sigma_s": self.sigma_s, "b": self.b, "c": self.c,
                        "p_diff": self.p, "n_p": self.n_p}
            m = {name: dr.clip(tex.eval_1(si, active), *self.ranges[name]) for name, tex in self.params.items()}
            lo, hi = self.general.domain["p_diffraction"]
            m["p_diff"], m["n_p"] = dr.clip(m["p"], lo, hi), self.general.n_p(m["p"])
            return m

        # -- maths.md section 7, one wavelength at a time -----------------------------------------
        def _g1(self, m, cos_t, sin_t):
            if self.general is not None:
                return self.general.g1_at(m["p"], m["beta"], sin_t, cos_t)
            return self.g1.eval(mi.Point1f(self.g1_axis.pos(bounded_log_tan(self.g1_axis.enc, sin_t, cos_t))))[0]

        @staticmethod
        def _attenuation(m, cos_d, lam):
            x = 4.0 * math.pi * m["sigma_s"] * cos_d / lam
            return dr.exp(-x * x)

        @staticmethod
        def _ndf(m, cos_h, sin_h):
            beta2 = m["beta"] * m["beta"]
            tan2 = dr.square(sin_h / cos_h) / beta2
            return m["n_p"] / beta2 * dr.exp(-dr.power(tan2, m["p"])) / dr.square(dr.square(cos_h))

        def _lobe(self, m, u, theta_h, cos_h, sin_h):
            """C(theta_h; u) of maths.md section 4 at the material's c, p, beta."""
            general = self.general
            if self.lobe == "exact":
                if general is not None:
                    return general.lobe_exact(u, m["c"], m["p_diff"], m["beta"], theta_h)
                d = self.lobe_angle
                v = lobe_angle(theta_h, u, d["edge_d"], d["theta_cap"], d["v_anchor"])
                pos = mi.Point2f(self.lobe_v.pos(v), self.lobe_u.at(u))
                return dr.exp(self.ln_c.eval(pos)[0])
            if general is not None:
                s_cos, g_cos = general.fitted_cos(u, m["c"], m["p_diff"], m["beta"])
            else:
                s_cos, g_cos = self.fit.eval(mi.Point1f(self.fit_u.at(u)))
            return s_cos * dr.power(1.0 + 4.0 * g_cos * g_cos * sin_h * sin_h, -(m["c"] + 1.0) / 2.0) * cos_h * cos_h

        def _ln_r(self, m, sin_t, bb):
            """ln R(s = sin theta, B = bb, c)."""
            if self.general is not None:
                return dr.log(self.general.r_at(sin_t, bb, m["c"]))
            return self.ln_r.eval(mi.Point2f(self.r_axes[1].at(bb), self.r_axes[0].at(sin_t)))[0]

        def _parts(self, g, lam, scale=None):
            """(specular, diffraction) parts of rho / F (no cosine) at one wavelength lam (um), given the
            geometry g of _geometry. Compensated: R -> sqrt(R(sin_i) R(sin_o)) and the diffraction part
            times scale = g(cos_i) g(cos_o)."""
            if not self.diffracts:
                return g["d_g2"], 0.0
            m = g["m"]
            spec_a = self._attenuation(m, g["cos_d"], lam)
            bb = m["b"] / lam
            ln_r = self._ln_r(m, g["sin_i"], bb)
            if self.compensated:
                ln_r = 0.5 * (ln_r + self._ln_r(m, g["sin_o"], bb))
            c_lobe = self._lobe(m, bb * g["cos_d"], g["theta_h"], g["cos_h"], g["sin_h"])
            k = (m["c"] - 1.0) * bb * bb / (2.0 * math.pi) * dr.exp(-ln_r) * m["n_p"] / (m["beta"] * m["beta"]) * c_lobe
            if scale is not None:
                k = k * scale
            return spec_a * g["d_g2"], (1.0 - spec_a) * g["g2"] * k

        def _rho(self, g, lam, fresnel):
            spec, diff = self._parts(g, lam)
            return spec + diff if fresnel is None else (spec + diff) * fresnel

        def _geometry(self, m, wi, wo):
            cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            h = dr.normalize(wi + wo)
            sin_h = dr.sqrt(dr.square(h.x) + dr.square(h.y))
            sin_i = dr.sqrt(dr.square(wi.x) + dr.square(wi.y))
            sin_o = dr.sqrt(dr.square(wo.x) + dr.square(wo.y))
            g1i, g1o = self._g1(m, cos_i, sin_i), self._g1(m, cos_o, sin_o)
            g2 = dr.select((g1i > 0) & (g1o > 0), 1.0 / (1.0 / g1i + 1.0 / g1o - 1.0), 0.0)
            cos_h = h.z
            # i.h = o.h; compensated or a plastic (reciprocal where it does not diffract), their mean, so that
            # rho(i, o) = rho(o, i) to the last bit
            cos_d = 0.5 * (dr.dot(wi, h) + dr.dot(wo, h)) if self.compensated or self.plastic else dr.dot(wi, h)
            g = {"m": m, "wi": wi, "wo": wo, "cos_i": cos_i, "cos_o": cos_o, "sin_i": sin_i, "sin_o": sin_o, "h": h, "cos_h": cos_h, "sin_h": sin_h,
                 "theta_h": _theta(cos_h, sin_h), "cos_d": dr.clip(cos_d, 0.0, 1.0), "g2": g2}
            g["d_g2"] = self._ndf(m, cos_h, sin_h) * g2 / (4.0 * cos_i * cos_o)
            return g

        def _valid(self, ctx, si, wo, active):
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            return ok & ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0)

        def _value(self, ctx, si, wo, g, active):
            """rho cos_o per wavelength of the spectral sample."""
            eta = None if self.eta is None else self.eta.eval(si, active)
            k = None if self.k is None else self.k.eval(si, active)
            out = mi.UnpolarizedSpectrum(0.0)
            for j in range(len(si.wavelengths)):
                lam = si.wavelengths[j] * 1e-3
                if self.plastic:
                    fresnel, f_avg = _dielectric(g["cos_d"], self.ior), lambda: self.f_avg
                elif eta is not None:
                    fresnel, f_avg = _fresnel(g["cos_d"], eta[j], k[j]), lambda j=j: _fresnel_avg(lambda mu: _fresnel(mu, eta[j], k[j]))
                else:
                    fresnel, f_avg = None, None
                if self.compensated:
                    rho, e = self._compensated(g, lam, fresnel, f_avg)
                else:
                    rho, e = self._rho(g, lam, fresnel), None
                if self.plastic:
                    rho = rho + self._layer(g, lam, e, f_avg)
                out[j] = rho * g["cos_o"]
            return out

        def _albedo(self, m, sin_t, cos_t, lam):
            """(g, E_c) at the angle theta: the folder's albedo table; in general mode (1, epd_albedo(p, beta, theta)), the
            microfacet part's albedo (docs/runtimes.md "General mode")."""
            if self.general is not None:
                return 1.0, self.general.albedo(m["p"], m["beta"], sin_t, cos_t)
            g, e, _ = self.albedo.at(sin_t, cos_t, lam)
            return g, e

        def _albedo_avg(self, m, lam):
            return self.albedo.avg(lam) if self.general is None else self.general.albedo_avg(m["p"], m["beta"])

        def _compensated(self, g, lam, fresnel, f_avg):
            """rho of energy = "compensated" at lam, F [f_s + g_i g_o f_d_sym] + F_ms f_ms (docs/runtimes.md), and
            (E_c(i), E_c(o), E_c_avg)."""
            m = g["m"]
            g_i, e_i = self._albedo(m, g["sin_i"], g["cos_i"], lam)
            g_o, e_o = self._albedo(m, g["sin_o"], g["cos_o"], lam)
            spec, diff = self._parts(g, lam, g_i * g_o if self.general is None else None)
            e_avg = self._albedo_avg(m, lam)
            loss = 1.0 - e_avg
            f_ms = dr.select(loss > 1e-6, dr.maximum(1.0 - e_i, 0.0) * dr.maximum(1.0 - e_o, 0.0) / (math.pi * dr.maximum(loss, 1e-6)), 0.0)
            if fresnel is None:
                return spec + diff + f_ms, (e_i, e_o, e_avg)
            return (spec + diff) * fresnel + f_ms * _ms_factor(e_avg, f_avg()), (e_i, e_o, e_avg)

        def _transmitted(self, sin_t, cos_t, lam, e_c, ms):
            """T = max(1 - E_F, 0), or compensated max(1 - E_Fc - (1 - E_c) m, 0): what the interface lets into the layer."""
            e_f = self.interface.at(sin_t, cos_t, lam)[0]
            return dr.maximum(1.0 - e_f if e_c is None else 1.0 - e_f - dr.maximum(1.0 - e_c, 0.0) * ms, 0.0)

        def _diffuse_share(self, t_avg, lam):
            """(share of the light let in that leaves as the Lambertian lobe T(o) / (pi T_avg), single-scattering albedo),
            r = 1 - T_avg / eta^2: a plastic's d_eff = d (1 - r) / (1 - d r) (section 10), 0; a subsurface medium's
            R_d (1 - alpha s_max), alpha (section 11)."""
            a = _piecewise_linear(*self.diffuse, lam) if isinstance(self.diffuse, tuple) else self.diffuse
            r = 1.0 - t_avg / self.ior_sq
            if not self.subsurface:
                return a * (1.0 - r) / (1.0 - a * r), 0.0
            alpha = a / (a + (1.0 - a) * (1.0 - self.phase_g))
            s3 = dr.sqrt(dr.maximum(3.0 * (1.0 - a), 0.0))
            r_d = 0.5 * a * (1.0 + dr.exp(-4.0 / 3.0 * (1.0 + r) / (1.0 - r) * s3)) * dr.exp(-s3)
            return r_d * (1.0 - alpha * self.single_max), alpha

        def _layer(self, g, lam, e, f_avg):
            """The layer's lobes (docs/maths.md sections 10, 11): share T(i) T(o) / (pi T_avg), and a subsurface medium's
            single scattering alpha T(i) T(o) p_g(t_i . o') / (eta^2 (mu_i' + mu_o')); e: compensated's E_c's."""
            e_i, e_o, e_avg = e if e is not None else (None, None, None)
            ms = _ms_factor(e_avg, f_avg()) if e is not None else 0.0
            t_avg = 1.0 - self.interface.avg(lam) - (0.0 if e is None else (1.0 - e_avg) * ms)
            t_i = self._transmitted(g["sin_i"], g["cos_i"], lam, e_i, ms)
            t_o = self._transmitted(g["sin_o"], g["cos_o"], lam, e_o, ms)
            share, alpha = self._diffuse_share(t_avg, lam)
            rho = share * t_i * t_o / (math.pi * dr.maximum(t_avg, 1e-30))
            if self.subsurface:
                wi, wo, eta2 = g["wi"], g["wo"], self.ior_sq
                mu_i = dr.sqrt(dr.maximum(1.0 - dr.square(g["sin_i"]) / eta2, 0.0))
                mu_o = dr.sqrt(dr.maximum(1.0 - dr.square(g["sin_o"]) / eta2, 0.0))
                c = -(wi.x * wo.x + wi.y * wo.y) / eta2 - mu_i * mu_o
                q = 1.0 + dr.square(self.phase_g) - 2.0 * self.phase_g * c
                p_g = (1.0 - dr.square(self.phase_g)) / (4.0 * math.pi * q * dr.sqrt(q))
                rho = rho + alpha * t_i * t_o * p_g / (eta2 * (mu_i + mu_o))
            return dr.select(t_avg > 0, rho, 0.0)

        # -- sampling: docs/runtimes.md -------------------------------------------------------------
        def _w_d(self, si, m):
            if not self.diffracts:
                return 0.0
            a = self._attenuation(m, mi.Frame3f.cos_theta(si.wi), si.wavelengths[0] * 1e-3)
            w = dr.clip(1.0 - a, W_MIN, 1.0 - W_MIN)
            return w if self.general is None else dr.select(m["sigma_s"] > 0, w, 0.0)

        def _w_ms(self, si, m):
            """The cosine strategy's share. A conductor (compensated): the multiple-scattering lobe's albedo with
            F = 1, 1 - E_c(cos_i) at the hero wavelength, at most W_MS_MAX. A plastic or subsurface material: the albedo
            of its layer's lobes (T(i) times d_eff, or R_d (1 - alpha s_max) + alpha s_max, a bound of the subsurface
            lobes'), and (1 - E_c) m compensated, over theirs plus the interface's, at most W_MS_MAX."""
            wi, lam = si.wi, si.wavelengths[0] * 1e-3
            sin_i, cos_i = dr.sqrt(dr.square(wi.x) + dr.square(wi.y)), mi.Frame3f.cos_theta(wi)
            e = self._albedo(m, sin_i, cos_i, lam)[1] if self.compensated else None
            if not self.plastic:
                return dr.clip(1.0 - e, 0.0, W_MS_MAX)
            ms, t_avg = 0.0, 1.0 - self.interface.avg(lam)
            if e is not None:
                e_avg = self._albedo_avg(m, lam)
                ms = _ms_factor(e_avg, self.f_avg)
                t_avg = t_avg - (1.0 - e_avg) * ms
            share, alpha = self._diffuse_share(t_avg, lam)
            if self.subsurface:  # the single-scattering lobe's albedo is at most alpha s_max T(i)
                share = share + alpha * self.single_max
            cosine = dr.select(t_avg > 0, share * self._transmitted(sin_i, cos_i, lam, e, ms), 0.0)
            if e is not None:
                cosine = cosine + dr.maximum(1.0 - e, 0.0) * ms
            e_f = dr.maximum(self.interface.at(sin_i, cos_i, lam)[0], 0.0)
            return dr.select(cosine > 0, dr.minimum(cosine / (cosine + e_f), W_MS_MAX), 0.0)

        @staticmethod
        def _u0(si, m):
            return m["b"] / (si.wavelengths[0] * 1e-3) * mi.Frame3f.cos_theta(si.wi)

        def _sample_specular(self, m, xi):
            """theta_m of the specular strategy (the EPD's D(m) cos theta_m) at the uniform xi."""
            if self.general is not None:
                return self.general.sample_epd(m["p"], m["beta"], xi)
            return self.spec_q.eval(mi.Point1f(self.spec_axis.pos(encode({"kind": "asin_sqrt"}, xi))))[0]

        def _specular_density(self, m, g):
            """The density in theta_h that _sample_specular realises, exactly."""
            if self.general is not None:
                return self.general.epd_density(m["p"], m["beta"], g["sin_h"], g["cos_h"])
            return quantile_density(self.spec_buf, 0, self.spec_n, g["theta_h"])

        def _sample_lobe(self, si, m, xi):
            """theta_h of the diffraction strategy at the uniform xi: the folder's zh_lobe_sampling at u_0, or in general
            mode the fitted lobe's closed-form inverse CDF (docs/runtimes.md "General mode")."""
            u0 = self._u0(si, m)
            if self.general is not None:
                return self.general.sample_lobe(u0, m["c"], m["p_diff"], m["beta"], xi)
            pos = mi.Point2f(self.samp_xi.pos(encode({"kind": "asin_sqrt"}, xi)), self.samp_u.at(u0))
            return self.samp_q.eval(pos)[0]

        def _lobe_density(self, si, m, g):
            """The density in theta_h that _sample_lobe realises, exactly."""
            u0 = self._u0(si, m)
            if self.general is not None:
                return self.general.lobe_density(u0, m["c"], m["p_diff"], m["beta"], g["sin_h"], g["cos_h"])
            x = (encode(self.samp_u.enc, u0) - self.samp_u.e0) / self.samp_u.step
            k = dr.clip(mi.Int(dr.floor(x)), 0, self.samp_u.n - 2)
            t = dr.clip(x - mi.Float(k), 0.0, 1.0)
            row = mi.UInt32(k) * self.samp_n
            return quantile_density(self.samp_buf, row, self.samp_n, g["theta_h"], (row + self.samp_n, t))

        def _pdf(self, si, g):
            m, sin_h = g["m"], g["sin_h"]
            dens = self._specular_density(m, g)
            if self.diffracts:
                w_d = self._w_d(si, m)
                dens = (1.0 - w_d) * dens + w_d * self._lobe_density(si, m, g)
            cos_hd = dr.maximum(dr.dot(si.wi, g["h"]), 1e-30)
            pdf = dr.select(sin_h > 0, dens / (2.0 * math.pi * sin_h) / (4.0 * cos_hd), 0.0)
            if self.compensated or self.plastic:
                w_ms = self._w_ms(si, m)
                pdf = (1.0 - w_ms) * pdf + w_ms * dr.maximum(g["cos_o"], 0.0) / math.pi
            return pdf

        def eval_parts(self, si, wo, active=True):
            """(specular, diffraction) parts of rho / F, without the cosine, at the hero wavelength (tests)."""
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            spec, diff = self._parts(self._geometry(self._material(si, ok), si.wi, wo), si.wavelengths[0] * 1e-3)
            return dr.select(ok, spec, 0.0), dr.select(ok, diff, 0.0)

        def eval(self, ctx, si, wo, active=True):
            ok = self._valid(ctx, si, wo, active)
            g = self._geometry(self._material(si, ok), si.wi, wo)
            return dr.select(ok, self._value(ctx, si, wo, g, ok), 0.0)

        def pdf(self, ctx, si, wo, active=True):
            ok = self._valid(ctx, si, wo, active)
            return dr.select(ok, self._pdf(si, self._geometry(self._material(si, ok), si.wi, wo)), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            ok = self._valid(ctx, si, wo, active)
            g = self._geometry(self._material(si, ok), si.wi, wo)
            return dr.select(ok, self._value(ctx, si, wo, g, ok), 0.0), dr.select(ok, self._pdf(si, g), 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            mat = self._material(si, active)
            w_d = self._w_d(si, mat)
            xi1 = sample2.x
            cosine_strategy = self.compensated or self.plastic
            if cosine_strategy:  # the cosine strategy first, with share w_ms
                w_ms = self._w_ms(si, mat)
                cosine = xi1 < w_ms
                xi_ms = xi1 / dr.maximum(w_ms, 1e-30)
                xi1 = dr.select(cosine, 0.0, (xi1 - w_ms) / (1.0 - w_ms))
            lobe = xi1 < w_d
            xi = dr.clip(dr.select(lobe, xi1 / dr.maximum(w_d, 1e-30), (xi1 - w_d) / (1.0 - w_d)), 0.0, 1.0)
            theta = self._sample_specular(mat, xi)
            if self.diffracts:
                theta = dr.select(lobe, self._sample_lobe(si, mat, xi), theta)
            sin_t, cos_t = dr.sincos(theta)
            sin_p, cos_p = dr.sincos(2.0 * math.pi * sample2.y)
            m = mi.Vector3f(sin_t * cos_p, sin_t * sin_p, cos_t)
            wo = mi.reflect(si.wi, m)
            if cosine_strategy:  # cosine-weighted: sin^2 theta_o = xi_ms, the same phi (docs/runtimes.md)
                r2 = dr.clip(xi_ms, 0.0, 1.0)
                r = dr.sqrt(r2)
                wo = dr.select(cosine, mi.Vector3f(r * cos_p, r * sin_p, dr.sqrt(1.0 - r2)), wo)
            ok = self._valid(ctx, si, wo, active)
            g = self._geometry(mat, si.wi, wo)
            pdf = dr.select(ok, self._pdf(si, g), 0.0)
            ok &= pdf > 0
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo, bs.pdf, bs.eta = wo, dr.select(ok, pdf, 0.0), 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            value = self._value(ctx, si, wo, g, ok)
            return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

        def to_string(self):
            return f"TwoScaleBSDF[material={self.name}, tables={self.folder}, lobe={self.lobe}, energy={self.energy}]"

    return TwoScaleBSDF


_CLASSES = {}  # variant -> plugin class


def register():
    """Registers `twoscale` for the current variant (importing the package does it for every spectral
    variant set)."""
    if mi.variant() not in _CLASSES:
        _CLASSES[mi.variant()] = _make_class()
    cls = _CLASSES[mi.variant()]
    mi.register_bsdf("twoscale", lambda props: cls(props))
