#!/bin/sh
# Regenerates bbm.json, the golden values of the comparison models low_smooth and he (bbm_golden.cpp says
# what they are), with the reference implementation: bsdfbenchmark/bbm's headers, native backbone.
#
#   pipeline/fit/golden/bbm_golden.sh [BBM_CHECKOUT]
#
# BBM_CHECKOUT: a checkout of https://github.com/bsdfbenchmark/bbm at the commit below (without one, the
# script clones it into a temporary folder). Needs git and a C++20 compiler (g++ 12 or later; $CXX).
# Only bbm.json is committed; tests/suite/fit/compare.rs checks twoscale's evaluations against it.
set -eu
COMMIT=9807fb38d7ab51802f3a0fe0f65cf763cb01a0f4
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bbm=${1:-}
if [ -z "$bbm" ]; then
    bbm="$work/bbm"
    git clone -q https://github.com/bsdfbenchmark/bbm "$bbm"
    git -C "$bbm" checkout -q "$COMMIT"
fi
${CXX:-g++} -std=c++20 -O1 -I"$bbm/include" -I"$bbm/backbone/native/include" "$here/bbm_golden.cpp" -o "$work/golden"
"$work/golden" > "$work/bbm.json"
mv "$work/bbm.json" "$here/bbm.json"
echo "wrote $here/bbm.json"
