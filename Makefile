# twoscale: `make tables` builds the tables, `make test` checks them.
PRESET ?= default
CARGO ?= cargo
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: tables test lint manifests bench bench-c bench-brdf bench-mitsuba bench-webgl deps browser pyenv renders fit-measured clean

# HDF5 headers and pkg-config for the hdf5 crate; LLVM 19 for Mitsuba's llvm_* variants; minisign, the
# reference the signature tests check twoscale's signatures against (Debian packages).
deps:
	@if ! dpkg -s libhdf5-dev >/dev/null 2>&1 || ! command -v pkg-config >/dev/null 2>&1 || ! dpkg -s libllvm19 >/dev/null 2>&1 \
		|| ! command -v minisign >/dev/null 2>&1; then \
		echo "installing libhdf5-dev, pkg-config, libllvm19 and minisign"; \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq libhdf5-dev pkg-config libllvm19 minisign; \
	fi

# Chromium for the WebGL runtime's browser tests (Debian's package: headless, WebGL2 by SwiftShader).
browser:
	@command -v chromium >/dev/null 2>&1 || { echo "installing chromium"; \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium; }

# In .venv: numpy, h5py, scipy, cryptography (Ed25519 for signed bundles), Mitsuba 3, matplotlib (the figures of
# examples/fit/measured.py), pytest and ruff; the
# reader package twoscale_tables (pipeline/tables/python), the Mitsuba plugin twoscale_mitsuba (runtimes/mitsuba) and the tests' helper modules
# (runtimes/testing: twoscale_c, reference, ...; no script edits sys.path), all installed editable (reinstalled
# only when .venv's is not this checkout's or lacks a module added since; the helpers are top-level modules, hence their own check).
PYREADER := pipeline/tables/python
PYMITSUBA := runtimes/mitsuba
editable_here = .venv/bin/python -c "import importlib.util as u, os, sys; s = u.find_spec('$(1)'); \
	sys.exit(s is None or os.path.dirname(os.path.realpath(s.origin)) != os.path.realpath('$(2)/$(1)'))" 2>/dev/null
pyenv:
	@.venv/bin/python -c "import numpy, h5py, scipy, cryptography, mitsuba, matplotlib, pytest" 2>/dev/null && [ -x .venv/bin/ruff ] \
		|| { python3 -m venv .venv && .venv/bin/pip install -q numpy h5py scipy cryptography mitsuba matplotlib pytest ruff; }
	@$(call editable_here,twoscale_tables,$(PYREADER)) || .venv/bin/pip install -q -e $(PYREADER)
	@$(call editable_here,twoscale_mitsuba,$(PYMITSUBA)) || .venv/bin/pip install -q --no-deps -e $(PYMITSUBA)
	@.venv/bin/python -c "import importlib.util as u, os, sys; sys.exit(any(u.find_spec(m) is None or os.path.realpath(u.find_spec(m).origin) != os.path.realpath(f'runtimes/testing/{m}.py') for m in ('twoscale_c', 'nbrdf', 'mitsuba_measured', 'shared_data')))" 2>/dev/null || .venv/bin/pip install -q --no-deps -e runtimes/testing

# Mitsuba's llvm_* variants load this LLVM (14 and 15 do not work).
export DRJIT_LIBLLVM_PATH ?= /usr/lib/x86_64-linux-gnu/libLLVM-19.so

# Every table of PRESET (default or paper) into tables-out/$(PRESET)/.
tables: deps
	$(CARGO) run --release --bin twoscale -- build --preset $(PRESET)

# Unit, known-answer and end-to-end tests; regenerates both presets and
# compares their data checksums with manifests/; checks the C and Python readers.
test: deps browser pyenv
	$(CARGO) test --release --workspace

# Formatting and lints: rustfmt, clippy (every target and feature, warnings are errors), ruff; the README and
# ARCHITECTURE.md within their agreed sizes (10,000 and 8,704 bytes: ARCHITECTURE.md's was 8,192 until it had to
# place examples/, manifests/ and its readers, and the fit crate's modules, condensed elsewhere as far as it read well).
lint: deps pyenv
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets --all-features -- -D warnings
	.venv/bin/ruff check .
	@for f in README.md:10000 ARCHITECTURE.md:8704; do n=$$(wc -c < $${f%:*}); [ $$n -le $${f#*:} ] \
		|| { echo "$${f%:*}: $$n bytes, over $${f#*:}"; exit 1; }; done

# Refresh the committed manifests after an intended change of table data.
manifests: deps
	$(CARGO) run --release --bin twoscale -- build --quiet --preset paper
	$(CARGO) run --release --bin twoscale -- build --quiet --preset default
	for p in paper default; do mkdir -p manifests/$$p && cp tables-out/$$p/*.manifest.json manifests/$$p/; done

# The pictures of examples/mitsuba into docs/renders/ (the materials of render_materials.toml and the default
# preset, built if needed).
RENDER_MATERIALS := tables-out/scene-render_materials
renders: deps pyenv
	$(CARGO) run --release --bin twoscale -- build --quiet --scene examples/mitsuba/render_materials.toml
	$(CARGO) run --release --bin twoscale -- build --quiet --preset default
	.venv/bin/python -m examples.mitsuba.render --materials $(RENDER_MATERIALS) --tables tables-out/default --out docs/renders
	$(MAKE) --no-print-directory browser
	.venv/bin/python runtimes/webgl/tools/screenshot.py --dir $(RENDER_MATERIALS)/b0.5 --out docs/renders/explorer.png
	.venv/bin/python -m examples.fit.render --out docs/renders/fit.png
	.venv/bin/python -m examples.fit.compare --out docs/renders/fit_compare.png

# docs/fit_measured.md and its figures: `twoscale fit` on every shared measured file (the 50 MERL stand-ins, the
# 14 RGL files), each fit's render against the file's and the published fits' (about half an hour on 2 cores).
fit-measured: deps pyenv
	$(CARGO) build --release --bin twoscale
	$(CARGO) run --release --bin twoscale -- build --quiet --preset default
	.venv/bin/python -m examples.fit.measured

# The Mitsuba BSDF's throughput against roughconductor, and general mode against the per-material BSDF, side by
# side (examples/mitsuba/bench.py).
bench-mitsuba: deps pyenv
	$(CARGO) run --release --bin twoscale -- build --quiet --scene examples/mitsuba/render_materials.toml
	$(CARGO) run --release --bin twoscale -- build --quiet --preset default
	.venv/bin/python -m examples.mitsuba.bench --materials $(RENDER_MATERIALS) --tables tables-out/default

# The explorer's sphere pass against a GGX pass on the same page (runtimes/webgl/tools/bench.py), in headless
# Chromium: SwiftShader, a CPU rasteriser, where no GPU is (the ratio is the figure, not the times).
bench-webgl: deps browser pyenv
	$(CARGO) run --release --bin twoscale -- build --quiet --scene examples/mitsuba/render_materials.toml
	for e in single compensated; do .venv/bin/python runtimes/webgl/tools/bench.py --dir $(RENDER_MATERIALS)/nickel --energy $$e; done

bench: deps
	$(CARGO) bench -p twoscale-quality --features criterion --bench paper --bench lookup

# The C reader's lookup cost (pipeline/tables/c/bench/lookup_bench.c): the merl_nickel
# scene's sub-domain zh_lobe (control variates) at 1e6 random points, gcc -O2, against
# the plain multilinear interpolation of c_lobe alone.
BENCH_C := target/bench-c
bench-c: deps
	$(CARGO) run --release --bin twoscale -- build --quiet --scene examples/scenes/merl_nickel.toml --table zh_lobe
	$(CARGO) run --release --bin twoscale -- export --format c-header --table zh_lobe --preset scene-merl_nickel --out $(BENCH_C)
	$(CC) -std=c99 -pedantic -O2 -Wall -Wextra -Werror -I pipeline/tables/c \
		-include $(BENCH_C)/twoscale_zh_lobe_scene_merl_nickel.h -DTABLE=twoscale_zh_lobe_scene_merl_nickel \
		pipeline/tables/c/bench/lookup_bench.c -o $(BENCH_C)/lookup_bench -lm
	$(BENCH_C)/lookup_bench

# The C reference BRDF's cost (runtimes/c/bench/brdf_bench.c): eval, pdf and sample of the
# merl_nickel scene's material folder at 1e6 random (wi, wo, lambda), gcc -O2, against a plain GGX eval.
bench-brdf: deps
	$(CARGO) run --release --bin twoscale -- build --quiet --scene examples/scenes/merl_nickel.toml
	$(CARGO) run --release --bin twoscale -- export --quiet --format c-header --dir tables-out/scene-merl_nickel/nickel --out $(BENCH_C)
	$(CC) -std=c99 -pedantic -O2 -Wall -Wextra -Werror -I pipeline/tables/c -I runtimes/c -I $(BENCH_C) \
		-include $(BENCH_C)/twoscale_material_scene_merl_nickel_nickel.h -DMATERIAL=twoscale_material_scene_merl_nickel_nickel \
		runtimes/c/bench/brdf_bench.c -o $(BENCH_C)/brdf_bench -lm
	$(BENCH_C)/brdf_bench

clean:
	rm -rf tables-out .venv
