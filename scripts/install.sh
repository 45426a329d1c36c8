#!/usr/bin/env bash
# Installs raddiff as a C/C++ package into PREFIX:
#   PREFIX/include/raddiff/raddiff.h            the committed header, byte for byte
#   PREFIX/lib/libraddiff.a                     static library
#   PREFIX/lib/libraddiff.so.X.Y.Z              shared library (SONAME libraddiff.so.0.MINOR before 1.0),
#   PREFIX/lib/libraddiff.so.0.MINOR, .so       with its symlinks
#   PREFIX/lib/pkgconfig/raddiff.pc             pkg-config (Libs.private: the static link deps)
#   PREFIX/lib/cmake/raddiff/raddiffConfig.cmake, raddiffConfigVersion.cmake
# The first five come from cargo-c (`cargo cinstall`, configured in Cargo.toml's
# [package.metadata.capi]), built once into a fixed staging tree and copied from there (installing
# into another prefix does not rebuild); cargo-c installs no CMake files, so this script adds them
# from cmake/.
#
# Usage: scripts/install.sh PREFIX [more `cargo cinstall` options]
#   e.g. scripts/install.sh /usr/local      (system prefix: no rpath or LD_LIBRARY_PATH needed)
#        scripts/install.sh "$HOME/.local"  (see docs/install.md for rpath)
# DESTDIR=/staging scripts/install.sh /usr  stages the files under /staging/usr (packagers).
# Needs cargo-c: scripts/ensure-cargo-c.sh
set -euo pipefail

if [ $# -lt 1 ] || [ -z "$1" ]; then
  echo "usage: $0 PREFIX [cargo cinstall options]" >&2
  exit 2
fi
prefix="$1"
shift
case "$prefix" in
  /*) ;;
  *) prefix="$(pwd)/$prefix" ;;
esac
root="$(cd "$(dirname "$0")/.." && pwd)"

if ! cargo cinstall --help >/dev/null 2>&1; then
  echo "cargo cinstall not found: run scripts/ensure-cargo-c.sh (or cargo install cargo-c --locked)" >&2
  exit 1
fi

# cargo-c rebuilds the library whenever the install paths differ from its last build's (they
# are part of its build fingerprint), so it always installs into the same staging tree under the
# target directory, and this script copies that tree into PREFIX: a new prefix costs a copy, not
# a build, while the release build is current (cargo still rebuilds after source changes).
target_dir="${CARGO_TARGET_DIR:-$root/target}"
case "$target_dir" in
  /*) ;;
  *) target_dir="$root/$target_dir" ;;
esac
stage="$target_dir/raddiff-install"
stage_prefix=/usr/local
rm -rf "$stage"
# --libdir: always PREFIX/lib (no multiarch lib/x86_64-linux-gnu), where the CMake files expect it.
# rustc's note listing the static library's native link dependencies reaches cargo-c's output
# without the list (cargo-c keeps it for raddiff.pc's Libs.private): drop it.
cargo cinstall --release --manifest-path "$root/Cargo.toml" --prefix "$stage_prefix" \
  --libdir "$stage_prefix/lib" --destdir "$stage" "$@" 2>&1 |
  awk '/^note: link against the following native artifacts/ { skip = 1; next }
       skip && /^[[:space:]]*$/ { skip = 0; next }
       { skip = 0; print }'

staged="${DESTDIR:-}$prefix"
from="$stage$stage_prefix"
install -d "$staged/include/raddiff" "$staged/lib/pkgconfig"
cp -a --remove-destination "$from/include/raddiff/." "$staged/include/raddiff/"
cp -a --remove-destination "$from/lib/"libraddiff.* "$staged/lib/"
# the pkg-config file names its prefix: the real one
sed "s|^prefix=.*|prefix=$prefix|" "$from/lib/pkgconfig/raddiff.pc" > "$staged/lib/pkgconfig/raddiff.pc.tmp"
mv "$staged/lib/pkgconfig/raddiff.pc.tmp" "$staged/lib/pkgconfig/raddiff.pc"

pc="$staged/lib/pkgconfig/raddiff.pc"
version="$(sed -n 's/^Version: *//p' "$pc")"
[[ "$version" =~ ^([0-9]+)\.([0-9]+)\.([0-9]+)$ ]] || { echo "no version in $pc" >&2; exit 1; }
major="${BASH_REMATCH[1]}" minor="${BASH_REMATCH[2]}" patch="${BASH_REMATCH[3]}"
# cargo-c's SONAME rule: 0.0.P -> .so.0.0.P, 0.M.P -> .so.0.M, M.m.p -> .so.M
if [ "$major" != 0 ]; then
  soversion="$major"
elif [ "$minor" != 0 ]; then
  soversion="0.$minor"
else
  soversion="0.0.$patch"
fi
[ -f "$staged/lib/libraddiff.so.$version" ] || { echo "missing $staged/lib/libraddiff.so.$version" >&2; exit 1; }
[ -L "$staged/lib/libraddiff.so.$soversion" ] || { echo "missing $staged/lib/libraddiff.so.$soversion" >&2; exit 1; }

cmakedir="$staged/lib/cmake/raddiff"
install -d "$cmakedir"
for f in raddiffConfig raddiffConfigVersion; do
  sed -e "s/@RADDIFF_VERSION@/$version/g" -e "s/@RADDIFF_SOVERSION@/$soversion/g" \
    "$root/cmake/$f.cmake.in" > "$cmakedir/$f.cmake.tmp"
  chmod 644 "$cmakedir/$f.cmake.tmp"
  mv "$cmakedir/$f.cmake.tmp" "$cmakedir/$f.cmake"
done
echo "raddiff $version installed into $staged (CMake package: $cmakedir)"
