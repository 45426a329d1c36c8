#!/usr/bin/env bash
# The real-scene benchmark: for every scene folder under --scenes (each holding one .obj with its
# MTL and an emitter), every view known for it and every size, runs `raddiff_embree --bench`
# (every metric tuned to equal records and swept over thresholds, against a converged reference,
# and path tracing at equal CPU time), denoises the path-tracing snapshots with Open Image Denoise
# (oidnDenoise from the pyoidn package), then writes report.md, report.csv and the figures into
# --out (examples/embree/report.py). References are cached under OUT/cache and reused while the
# scene files, the view and the settings are unchanged. docs/real-scenes.md explains it all.
#
# usage: examples/embree/bench.sh --scenes DIR --out DIR [--size N[,N...]] [--quick]
#                                 [--views main|all] [-- extra raddiff_embree options]
#   --size   image sizes (default 512)
#   --quick  a short run (fewer thresholds, fewer reference rays, two metrics' curves): for CI
#   --views  main: each scene's documented view (default); all: its other views too
# Known views: sponza (atrium, gallery), sibenik (nave, aisle). Any other folder needs a file
# `view` beside its .obj holding `name eye target fov` lines (eye and target as x,y,z).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"

scenes="" out="" sizes="512" quick=0 views="main" extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --scenes) scenes="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --size) sizes="$2"; shift 2 ;;
    --quick) quick=1; shift ;;
    --views) views="$2"; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) sed -n '10,17p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
  esac
done
[ -n "$scenes" ] && [ -n "$out" ] || { sed -n '10,17p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
[ -d "$scenes" ] || { echo "no scene folder $scenes" >&2; exit 1; }
mkdir -p "$out"
out="$(cd "$out" && pwd)"

# Python packages of the report and the denoiser, installed when missing.
if ! python3 -c 'import numpy, matplotlib, pyoidn' 2>/dev/null; then
  python3 -m pip install --quiet numpy matplotlib pyoidn >&2
fi
oidn="$(python3 -c 'import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), "oidn", "bin", "oidnDenoise"))')"
[ -x "$oidn" ] || { echo "oidnDenoise not found at $oidn" >&2; exit 1; }

binary="$(bash "$here/build.sh")"

# name eye target fov, per known scene (docs/real-scenes.md; the first is the documented view)
views_of() {
  case "$1" in
    sponza) printf '%s\n' "atrium -14,2.5,0 10,5,0 60" "gallery -9,7.6,-5.2 9,5.5,5 65" ;;
    sibenik) printf '%s\n' "nave -16,-11,0 10,-8,0 70" "aisle -14,-12.5,5 8,-10,-3 70" ;;
    *) [ -f "$2/view" ] && cat "$2/view" ;;
  esac
}

settings=()
if [ "$quick" = 1 ]; then
  settings=(--thresholds 2 --reference-rays 32768 --reference-grid 32 --floor-records 60 --floor-rays 8192
            --metrics split-sphere,bounded-split-sphere,hessian-anisotropic --pixel-gathers)
fi

start=$(date +%s)
for dir in "$scenes"/*/; do
  dir="${dir%/}"
  scene="$(basename "$dir")"
  obj="$(ls "$dir"/*.obj 2>/dev/null | head -n 1 || true)"
  [ -n "$obj" ] || continue
  n=0
  while read -r name eye target fov; do
    [ -n "$name" ] || continue
    n=$((n + 1))
    [ "$views" = all ] || [ "$n" = 1 ] || continue
    for size in ${sizes//,/ }; do
      run="$scene-$name-$size"
      echo "== $run"
      "$binary" --bench --obj "$obj" --eye "$eye" --target "$target" --fov "$fov" --size "$size" \
        --cache-dir "$out/cache" --out "$out/$run" "${settings[@]}" "${extra[@]}" | tee "$out/$run.log"
      [ -f "$out/$run-pt.csv" ] && python3 "$here/denoise.py" "$out/$run" "$oidn"
    done
  done < <(views_of "$scene" "$dir")
done
python3 "$here/report.py" "$out"
echo "bench: $(( $(date +%s) - start )) s wall"
