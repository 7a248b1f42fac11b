"""The `twoscale` Mitsuba BSDF in use: renders, benchmarks and inverse rendering (README.md here)."""
