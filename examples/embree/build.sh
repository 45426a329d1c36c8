#!/usr/bin/env bash
# Installs raddiff into target/embree-prefix (scripts/install.sh: cargo cinstall and the CMake
# package config) and builds the Embree renderer against that installed package
# (find_package(raddiff CONFIG REQUIRED), -DCMAKE_PREFIX_PATH) into target/embree/raddiff_embree.
# Installs what a Debian/Ubuntu machine lacks when run as root (cmake, g++, libembree-dev,
# libpng-dev; cargo-c through scripts/ensure-cargo-c.sh); otherwise names it and stops.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="$root/target/embree"
prefix="$root/target/embree-prefix"

missing=()
command -v cmake >/dev/null || missing+=(cmake)
command -v c++ >/dev/null || missing+=(g++)
[ -f /usr/include/embree3/rtcore.h ] || missing+=(libembree-dev)
[ -f /usr/include/png.h ] || missing+=(libpng-dev)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    echo "missing: ${missing[*]} (Debian/Ubuntu: sudo apt-get install ${missing[*]})" >&2
    exit 1
  fi
fi

bash "$root/scripts/ensure-cargo-c.sh" >&2
bash "$root/scripts/install.sh" "$prefix" >/dev/null
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$build" -j 2 >/dev/null
echo "$build/raddiff_embree"
