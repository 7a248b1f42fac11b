#!/usr/bin/env bash
# Makes vectors.json, the golden vectors every reader's tests check: for each
# point of points.json, the values `twoscale lookup --json` prints there.
#
#     pipeline/tables/golden/make.sh BUILD_ROOT
#
# BUILD_ROOT receives the tables first (incremental builds: nothing to do when
# they are current), as tests/suite/common/shared_tables.rs builds them for the tests:
#     twoscale build --quiet --preset paper --out BUILD_ROOT
#     twoscale build --quiet --scene examples/scenes/merl_nickel.toml --table epd_g1 --table epd_norm \
#         --table kcorr_renorm --table zh_convolution --table zh_lobe --table epd_albedo \
#         --table epd_albedo_avg --out BUILD_ROOT
#     twoscale build --quiet --scene examples/scenes/merl_nickel.toml --out BUILD_ROOT
#     twoscale build --quiet --scene pipeline/tables/golden/broad_lobe.toml --table zh_lobe --out BUILD_ROOT
#     twoscale build --quiet --scene examples/scenes/plastic.toml --out BUILD_ROOT
# The binary: $TWOSCALE, else target/release/twoscale. python3 only carries
# the JSON from the CLI to the file (values as the CLI prints them: shortest
# round trip, full f64 precision).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../../.." && pwd)"
root="${1:?usage: make.sh BUILD_ROOT}"
bin="${TWOSCALE:-$repo/target/release/twoscale}"
[ -x "$bin" ] || { echo "make.sh: no twoscale binary at $bin (cargo build --release, or set TWOSCALE)" >&2; exit 1; }
scene="$repo/examples/scenes/merl_nickel.toml"
"$bin" build --quiet --preset paper --out "$root"
"$bin" build --quiet --scene "$scene" --table epd_g1 --table epd_norm --table kcorr_renorm --table zh_convolution --table zh_lobe \
    --table epd_albedo --table epd_albedo_avg --out "$root"
"$bin" build --quiet --scene "$scene" --out "$root"
"$bin" build --quiet --scene "$here/broad_lobe.toml" --table zh_lobe --out "$root"
"$bin" build --quiet --scene "$repo/examples/scenes/plastic.toml" --out "$root"
python3 - "$bin" "$root" "$here/points.json" > "$here/vectors.json.tmp" <<'PY'
import json, subprocess, sys
bin_, root, points = sys.argv[1:]
version = subprocess.run([bin_, "--version"], check=True, capture_output=True, text=True).stdout.strip()
vectors = []
for p in json.load(open(points))["points"]:
    cmd = [bin_, "lookup", "--json", "--dir", f"{root}/{p['tables']}", p["table"]]
    for name, x in p["point"].items():
        cmd += ["--at", f"{name}={x}"]  # numbers as Python prints them (shortest round trip), or inf
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"make.sh: {' '.join(cmd)}: {out.stderr.strip()}")
    values = json.loads(out.stdout)["values"]
    vectors.append({"tables": p["tables"], "table": p["table"], "point": p["point"], "values": values})
lines = ",\n".join("    " + json.dumps(v, allow_nan=False) for v in vectors)
print(f'{{\n  "format": "twoscale-golden/1",\n  "generator": {json.dumps(version + " lookup --json")},\n'
      f'  "tolerance": {{"relative": 1e-12, "absolute": 1e-300}},\n  "vectors": [\n{lines}\n  ]\n}}')
PY
mv "$here/vectors.json.tmp" "$here/vectors.json"
echo "$here/vectors.json: $(grep -c '"table":' "$here/vectors.json") vectors"
