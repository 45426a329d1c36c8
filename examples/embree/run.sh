#!/usr/bin/env bash
# Builds raddiff (release static library) and the Embree example, renders the Cornell box with it
# and checks the output. Needs: cargo, g++, cmake, libembree-dev (Debian: apt-get install cmake
# libembree-dev). Usage: examples/embree/run.sh [extra raddiff_embree options]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="$root/target/embree"
out="$root/out/embree"

cargo build --release --lib --manifest-path "$root/Cargo.toml"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DRADDIFF_ROOT="$root" >/dev/null
cmake --build "$build" -j 2 >/dev/null
mkdir -p "$out"

# A small, quick configuration: split-sphere records, then occlusion-aware Hessian records.
"$build/raddiff_embree" --obj "$here/cornell.obj" --out "$out/cornell" --size 128 --gather 16x48 "$@" \
  | tee "$out/cornell.log"
"$build/raddiff_embree" --obj "$here/cornell.obj" --out "$out/cornell-hessian" --size 128 --gather 16x48 \
  --hessian 0.05 "$@" | tee "$out/cornell-hessian.log"

# The program exits non-zero when its own checks fail; check the files too.
for f in cornell cornell-hessian; do
  grep -q '^OK$' "$out/$f.log"
  test -s "$out/$f-irradiance.png"
  test -s "$out/$f-irradiance.pfm"
  test -s "$out/$f.rdc"
done
echo "embree example: OK (images and caches in $out)"
