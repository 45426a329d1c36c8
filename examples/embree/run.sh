#!/usr/bin/env bash
# Installs raddiff into target/embree-prefix (scripts/install.sh: cargo cinstall and the CMake package
# config), builds the Embree example against that installed package (find_package(raddiff CONFIG
# REQUIRED), -DCMAKE_PREFIX_PATH), renders the Cornell box with it and checks the output.
# Needs: cargo and cargo-c (installed when missing), g++, cmake, libembree-dev (Debian: apt-get
# install cmake libembree-dev). Usage: examples/embree/run.sh [extra raddiff_embree options]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$root/out/embree"

binary="$(bash "$here/build.sh")"
mkdir -p "$out"

# A small, quick configuration: split-sphere records, then occlusion-aware Hessian records with
# the Hessian's relative error tuned (--records) to the split sphere's record count, so that the two
# check errors compare at (nearly) equal records.
"$binary" --obj "$here/cornell.obj" --out "$out/cornell" --size 128 --gather 16x48 "$@" \
  | tee "$out/cornell.log"
records="$(sed -n 's/^pass 1: \([0-9][0-9]*\) records.*/\1/p' "$out/cornell.log")"
[ -n "$records" ] || { echo "no record count in $out/cornell.log" >&2; exit 1; }
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-hessian" --size 128 \
  --gather 16x48 --hessian 0.05 --records "$records" "$@" | tee "$out/cornell-hessian.log"
# The same two with the near field in the one-call API (raddiff_cache_irradiance_near_far_parts): a
# reach of 4 pixels, 16 x 16 short rays per pixel, records holding far fields.
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-near-split" --size 128 --gather 16x48 \
  --near-field 4,256 "$@" | tee "$out/cornell-near-split.log"
near_records="$(sed -n 's/^pass 1: \([0-9][0-9]*\) records.*/\1/p' "$out/cornell-near-split.log")"
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-near-hessian" --size 128 --gather 16x48 \
  --near-field 4,256 --hessian 0.05 --records "$near_records" "$@" | tee "$out/cornell-near-hessian.log"
# The split sphere's near-field run with the cache's open-fraction test (the near rays traced before
# each lookup, the records keeping their gathers' open fractions, the final lookups passing the
# pixels' own).
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-near-open" --size 128 --gather 16x48 \
  --near-field 4,256 --open-fraction-tolerance 0.1 "$@" | tee "$out/cornell-near-open.log"
# The same test keeping coverage: pixels that no record passes read the refused ones, so the fill
# makes about the records of the run without the test (about 750 here, against about 1,370 with the
# default test), and the reloaded cache (which keeps the choice) renders the identical image.
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-near-open-kept" --size 128 --gather 16x48 \
  --near-field 4,256 --open-fraction-tolerance 0.1 --open-fraction-keep-coverage "$@" |
  tee "$out/cornell-near-open-kept.log"
# The split sphere on one thread, read over its records' radii and over 1.5 times them (the cache's
# lookup radius scale): the same records, since misses are decided at the records' own radii.
for wide in 1 1.5; do
  "$binary" --obj "$here/cornell.obj" --out "$out/cornell-wide$wide" --size 128 --gather 16x48 --threads 1 \
    --lookup-scale "$wide" "$@" | tee "$out/cornell-wide$wide.log"
done
grep -q '^lookup radius scale: records read over 1.5 times their radii' "$out/cornell-wide1.5.log"
# The Hessian with its derivatives from smoothed strata (raddiff's derivative_smoothing).
"$binary" --obj "$here/cornell.obj" --out "$out/cornell-smoothed" --size 128 --gather 16x48 --hessian 0.05 \
  --smooth-derivative-strata 2,1 "$@" | tee "$out/cornell-smoothed.log"
grep -q '^derivative smoothing: 2 azimuthal and 1 polar passes' "$out/cornell-smoothed.log"
runs=(cornell cornell-hessian cornell-near-split cornell-near-hessian cornell-near-open cornell-wide1 cornell-wide1.5
  cornell-smoothed)

# The program exits non-zero when its own checks fail; check the files too.
for f in "${runs[@]}"; do
  grep -q '^OK$' "$out/$f.log"
  test -s "$out/$f-irradiance.png"
  test -s "$out/$f-irradiance.pfm"
  test -s "$out/$f.rdc"
done
records_of() { sed -n 's/^pass 1: \([0-9][0-9]*\) records.*/\1/p' "$out/$1.log"; }
error_of() { sed -n 's/^check: relative RMS error.*: \([0-9.eE+-]*\)$/\1/p' "$out/$1.log"; }
[ "$(records_of cornell-wide1)" = "$(records_of cornell-wide1.5)" ] ||
  { echo "the lookup radius scale changed the record count" >&2; exit 1; }
echo "lookup radius scale: $(records_of cornell-wide1) records, check error $(error_of cornell-wide1) at 1, $(error_of cornell-wide1.5) at 1.5"
awk -v n="$(records_of cornell)" -v x="$(error_of cornell)" -v m="$(records_of cornell-hessian)" \
  -v y="$(error_of cornell-hessian)" 'BEGIN {
    printf "equal records: split sphere %d records error %.4f, hessian %d records error %.4f (hessian/split sphere = %.2f)\n",
      n, x, m, y, (x > 0 ? y / x : 0) }'
grep -q '^near field: reach 4 px' "$out/cornell-near-hessian.log"
grep -q '^open-fraction test: records used only at pixels whose open fraction is within 0.1' "$out/cornell-near-open.log"
# The benchmark's near-field experiment on the same box, small and quick, with far-field gathers as
# raddiff_gather_far_field_radiance and raddiff_gather_far_field make them: each run exits non-zero
# unless every fill covers the image with finite, non-negative values.
for near in "--far-field-gathers" "--far-field-gathers --near-at-reach" "--far-field-gathers --near-at-reach --far-field-bins" \
  "--far-field-gathers --near-at-reach --far-field-bins --leak-guard 0.1,0 --open-fraction-bands 0.1" \
  "--far-field-gathers --near-at-reach --far-field-bins --leak-guard 0.1,0 --open-fraction-tolerance 0.1" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --open-fraction-tolerance 0.1 --lookup-scale 1.5" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --gradient-shrinkage 1 --hessian-shrinkage 1" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --hessian-shrinkage 1 --retraced-shrinkage-noise" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --noise-curvature 1 --gradient-noise-radius 1" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --smooth-derivative-strata 2,1" \
  "--far-field-gathers --near-at-reach --leak-guard 0.1,0 --open-fraction-tolerance 0.1 --adaptive-lookup 2,4"; do
  # shellcheck disable=SC2086 # the options are meant to split
  "$binary" --bench --obj "$here/cornell.obj" --out "$out/cornell-near" --size 64 --metrics split-sphere,hessian-anisotropic \
    --thresholds 1 --no-path-trace --reference-rays 4096 --near-field 4,64 $near > "$out/cornell-near.log"
  grep -q '^OK$' "$out/cornell-near.log"
done
# the adaptive lookup (the last run above) read the records over more than their own radii
awk '/^adaptive lookup:/ { n++; if ($NF + 0 <= 1) bad = 1 } END { exit !(n == 2 && !bad) }' "$out/cornell-near.log"
# Two runs that differ only in their samples (--noise-seed), each pixel also shown from its own
# gather (--pixel-gathers): what examples/embree/noise_split.py splits into noise and systematic parts.
for seed in 0 1; do
  "$binary" --bench --obj "$here/cornell.obj" --out "$out/cornell-seed$seed" --size 64 --metrics split-sphere,hessian-anisotropic \
    --thresholds 1 --no-path-trace --reference-rays 4096 --near-field 4,64 --far-field-gathers --near-at-reach \
    --pixel-gathers --noise-seed "$seed" > "$out/cornell-seed$seed.log"
  grep -q '^OK$' "$out/cornell-seed$seed.log"
  grep -q '^pixel gathers: every measured pixel from its own gather' "$out/cornell-seed$seed.log"
done
# The adaptive-gather experiment: a few record gathers traced 8 more times each
# (examples/embree/strata_allocation.py reads the files); and the smoothing experiment, whose
# far-field records keep their gradients.
rm -rf "$out/cornell-strata" && mkdir -p "$out/cornell-strata"
"$binary" --bench --obj "$here/cornell.obj" --out "$out/cornell-strata" --size 64 --gather 16x32 \
  --metrics split-sphere,hessian-anisotropic --thresholds 1 --no-path-trace --reference-rays 4096 \
  --near-field 4,64 --far-field-gathers --near-at-reach --smooth-records 1 \
  --strata-variance "$out/cornell-strata,5,8" > "$out/cornell-strata.log"
grep -q '^OK$' "$out/cornell-strata.log"
ls "$out/cornell-strata/"*.strata > /dev/null
# another noise seed draws other samples: the pixels' own gathers differ
if cmp -s "$out/cornell-seed0-pixel-gathers-pixels.csv" "$out/cornell-seed1-pixel-gathers-pixels.csv"; then
  echo "--noise-seed 1 drew the same samples as --noise-seed 0" >&2
  exit 1
fi
echo "embree example: OK (images and caches in $out)"
