"""Fitting measured and synthetic materials with `twoscale fit`, and rendering the fits (docs/fit.md)."""
