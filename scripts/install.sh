#!/usr/bin/env bash
# Installs raddiff as a C/C++ package into PREFIX:
#   PREFIX/include/raddiff/raddiff.h            the committed header, byte for byte
#   PREFIX/lib/libraddiff.a                     static library
#   PREFIX/lib/libraddiff.so.X.Y.Z              shared library (SONAME libraddiff.so.0.MINOR before 1.0),
#   PREFIX/lib/libraddiff.so.0.MINOR, .so       with its symlinks
#   PREFIX/lib/pkgconfig/raddiff.pc             pkg-config (Libs.private: the static link deps)
#   PREFIX/lib/cmake/raddiff/raddiffConfig.cmake, raddiffConfigVersion.cmake
# The first five come from cargo-c (`cargo cinstall`, configured in Cargo.toml's
# [package.metadata.capi]); cargo-c installs no CMake files, so this script adds them from cmake/.
#
# Usage: scripts/install.sh PREFIX [more `cargo cinstall` options]
#   e.g. scripts/install.sh /usr/local      (system prefix: no rpath or LD_LIBRARY_PATH needed)
#        scripts/install.sh "$HOME/.local"  (see docs/install.md for rpath)
# DESTDIR=/staging scripts/install.sh /usr  stages the files under /staging/usr (packagers).
# Needs cargo-c: cargo install cargo-c --locked
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
  echo "cargo cinstall not found: install cargo-c with \`cargo install cargo-c --locked\`" >&2
  exit 1
fi

destdir_args=()
if [ -n "${DESTDIR:-}" ]; then
  destdir_args=(--destdir "$DESTDIR")
fi
# --libdir: always PREFIX/lib (no multiarch lib/x86_64-linux-gnu), where the CMake files expect it.
cargo cinstall --release --manifest-path "$root/Cargo.toml" --prefix "$prefix" \
  --libdir "$prefix/lib" "${destdir_args[@]}" "$@"

staged="${DESTDIR:-}$prefix"
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
