"""The two-scale BRDF as a Mitsuba 3 BSDF: importing this package registers {"type": "twoscale"}.

    import mitsuba as mi
    mi.set_variant("llvm_ad_spectral")      # any unpolarised spectral variant, before or after the import
    import twoscale_mitsuba                  # noqa: F401  (registers the plugin)
    bsdf = mi.load_dict({"type": "twoscale", "tables": "tables-out/scene-materials/nickel"})

The plugin is registered for the spectral, unpolarised variant set at import and for every such
variant set later (Mitsuba's variant callbacks, as its own Python plugins do). Parameters: bsdf.py.
"""
import mitsuba as mi

from .bsdf import TwoScaleError, register

__all__ = ["TwoScaleError", "register"]


def _supported(variant):
    """The BSDF is spectral and unpolarised (docs/runtimes.md)."""
    return variant is not None and "spectral" in variant and "polarized" not in variant


def _on_variant(old, new):
    """Mitsuba calls this when the variant changes: register the plugin for the new one."""
    if _supported(new):
        register()


mi.detail.add_variant_callback(_on_variant)
if _supported(mi.variant()):
    register()
