#!/usr/bin/env bash
# CI check of the installed package: installs raddiff into a temporary prefix with
# scripts/install.sh, then builds and runs consumers the way C/C++ projects would:
#   (a) examples/consumer/hello.c (C99) through pkg-config, against the shared library
#       (with an rpath, and without one through LD_LIBRARY_PATH) and against the static library
#       (`pkg-config --static`, forcing libraddiff.a);
#   (b) examples/consumer/ (C++17, CMake) with find_package(raddiff CONFIG REQUIRED), both imported
#       targets raddiff::raddiff and raddiff::raddiff_static, before and after moving the prefix.
#   (c) the README's install lines verbatim (its `check-install: checkout` block in the checkout,
#       its `check-install: project` block in a project holding examples/consumer/ and hello.c as
#       app.c), with HOME a scratch directory so that "$HOME/.local" is a fresh user prefix, and a
#       second install into another prefix must not rebuild the library.
# It also checks the installed header is byte-identical to include/raddiff.h, the SONAME and the
# symlinks, and the pkg-config fields. Installs pkg-config, cmake, g++ when missing and run as root.
# Prints "check-install: OK" or "check-install: FAILED ..." last; exits non-zero on any failure.
# RADDIFF_KEEP_PREFIX=1 keeps the temporary directory.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"

step="setup"
tmp=""
finish() {
  local status=$?
  if [ -n "$tmp" ] && [ "${RADDIFF_KEEP_PREFIX:-0}" != 1 ]; then
    rm -rf "$tmp"
  elif [ -n "$tmp" ]; then
    echo "kept $tmp"
  fi
  if [ $status -eq 0 ]; then
    echo "check-install: OK (pkg-config shared and static, CMake raddiff::raddiff and raddiff::raddiff_static, the README's lines)"
  else
    echo "check-install: FAILED at step: $step (exit status $status)" >&2
  fi
  exit $status
}
trap finish EXIT
fail() { echo "check-install: $*" >&2; exit 1; }

step="system packages"
missing=()
command -v pkg-config >/dev/null || missing+=(pkg-config)
command -v cmake >/dev/null || missing+=(cmake)
command -v cc >/dev/null || missing+=(gcc)
command -v c++ >/dev/null || missing+=(g++)
command -v readelf >/dev/null || missing+=(binutils)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
  else
    fail "missing: ${missing[*]} (Debian/Ubuntu: sudo apt-get install ${missing[*]})"
  fi
fi
cargo cinstall --help >/dev/null 2>&1 || fail "cargo cinstall missing: cargo install cargo-c --locked"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/raddiff-check-install.XXXXXX")"
prefix="$tmp/prefix"

step="install (scripts/install.sh $prefix)"
bash "$root/scripts/install.sh" "$prefix"
echo "-- installed files:"
(cd "$prefix" && find . \( -type f -o -type l \) | sort | while read -r f; do
  if [ -L "$f" ]; then echo "   $f -> $(readlink "$f")"; else echo "   $f ($(stat -c %s "$f") bytes)"; fi
done)

step="installed files"
version="$(sed -n 's/^version = "\(.*\)"$/\1/p' "$root/Cargo.toml" | head -n 1)"
cmp "$root/include/raddiff.h" "$prefix/include/raddiff/raddiff.h" \
  || fail "installed header differs from include/raddiff.h"
cmp "$root/include/raddiff.hpp" "$prefix/include/raddiff/raddiff.hpp" \
  || fail "installed C++ wrapper differs from include/raddiff.hpp"
lib="$prefix/lib"
test -f "$lib/libraddiff.a" || fail "no libraddiff.a"
test -f "$lib/libraddiff.so.$version" && ! test -L "$lib/libraddiff.so.$version" \
  || fail "no libraddiff.so.$version"
soname="$(readelf -d "$lib/libraddiff.so.$version" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')"
[ -n "$soname" ] || fail "libraddiff.so.$version has no SONAME"
echo "-- SONAME: $soname"
[[ "$soname" == libraddiff.so.* ]] || fail "unexpected SONAME $soname"
[ "$(readlink "$lib/$soname")" = "libraddiff.so.$version" ] || fail "$soname is not a link to libraddiff.so.$version"
[ "$(readlink "$lib/libraddiff.so")" = "libraddiff.so.$version" ] || fail "libraddiff.so is not a link to libraddiff.so.$version"
test -f "$lib/cmake/raddiff/raddiffConfig.cmake" || fail "no raddiffConfig.cmake"
test -f "$lib/cmake/raddiff/raddiffConfigVersion.cmake" || fail "no raddiffConfigVersion.cmake"

step="pkg-config"
export PKG_CONFIG_PATH="$lib/pkgconfig"
[ "$(pkg-config --modversion raddiff)" = "$version" ] || fail "pkg-config version is not $version"
static_libs="$(pkg-config --static --libs raddiff)"
echo "-- pkg-config --cflags --libs raddiff: $(pkg-config --cflags --libs raddiff)"
echo "-- pkg-config --static --libs raddiff: $static_libs"
for l in -lpthread -ldl -lm -lrt; do
  [[ " $static_libs " == *" $l "* ]] || fail "Libs.private lacks $l"
done

cflags=(-std=c99 -Wall -Wextra -Werror -pedantic)
hello="$root/examples/consumer/hello.c"
needs_raddiff() { readelf -d "$1" | grep -q "NEEDED.*\[libraddiff\.so"; }

step="(a) C, pkg-config, shared library, rpath"
# Non-system prefix: an rpath (or LD_LIBRARY_PATH) finds libraddiff.so at run time; a system
# prefix (/usr, /usr/local after ldconfig) needs neither.
# shellcheck disable=SC2046
cc "${cflags[@]}" "$hello" -o "$tmp/hello-shared" $(pkg-config --cflags --libs raddiff) -lm \
  -Wl,-rpath,"$lib"
readelf -d "$tmp/hello-shared" | grep -q "NEEDED.*\[$soname\]" || fail "hello-shared does not need $soname"
env -u LD_LIBRARY_PATH "$tmp/hello-shared"

step="(a) C, pkg-config, shared library, LD_LIBRARY_PATH"
# shellcheck disable=SC2046
cc "${cflags[@]}" "$hello" -o "$tmp/hello-shared-norpath" $(pkg-config --cflags --libs raddiff) -lm
LD_LIBRARY_PATH="$lib" "$tmp/hello-shared-norpath"

step="(a) C, pkg-config --static, libraddiff.a"
# Both libraddiff.so and libraddiff.a are in the prefix and -lraddiff alone would take the .so:
# force the archive for raddiff only (the system libraries stay shared).
static_flags=()
for f in $static_libs; do
  if [ "$f" = -lraddiff ]; then
    static_flags+=(-Wl,-Bstatic -lraddiff -Wl,-Bdynamic)
  else
    static_flags+=("$f")
  fi
done
# shellcheck disable=SC2046
cc "${cflags[@]}" "$hello" -o "$tmp/hello-static" $(pkg-config --static --cflags raddiff) "${static_flags[@]}"
if needs_raddiff "$tmp/hello-static"; then fail "hello-static still needs libraddiff.so"; fi
env -u LD_LIBRARY_PATH "$tmp/hello-static"

step="(b) C++, CMake find_package, raddiff::raddiff and raddiff::raddiff_static"
consumer_build() {
  local build="$1" prefix_path="$2"
  cmake -S "$root/examples/consumer" -B "$build" -DCMAKE_PREFIX_PATH="$prefix_path" \
    -DCMAKE_BUILD_TYPE=Release
  cmake --build "$build" -j 2
  needs_raddiff "$build/consumer_shared" || fail "consumer_shared does not link libraddiff.so"
  if needs_raddiff "$build/consumer_static"; then fail "consumer_static links libraddiff.so"; fi
  env -u LD_LIBRARY_PATH "$build/consumer_shared"
  env -u LD_LIBRARY_PATH "$build/consumer_static"
}
consumer_build "$tmp/cmake-build" "$prefix"

step="(b) C++, CMake, relocated prefix"
mv "$prefix" "$tmp/moved-prefix"
consumer_build "$tmp/cmake-build-moved" "$tmp/moved-prefix"
grep -q "$tmp/moved-prefix/lib/libraddiff.so" \
  "$tmp/cmake-build-moved/CMakeFiles/consumer_shared.dir/link.txt" \
  || fail "the moved prefix's CMake targets do not point into the moved prefix"
step="(c) the README's install lines, verbatim, into a user prefix"
# the shell block that follows the line `<!-- check-install: NAME -->` in README.md
readme_block() {
  awk -v marker="<!-- check-install: $1 -->" '
    $0 == marker { found = 1; next }
    found && !inside && /^```sh$/ { inside = 1; next }
    inside && /^```$/ { exit }
    inside { print }' "$root/README.md"
}
checkout_lines="$(readme_block checkout)"
project_lines="$(readme_block project)"
[ -n "$checkout_lines" ] && [ -n "$project_lines" ] || fail "README.md lacks its check-install blocks"
home="$tmp/home"
mkdir -p "$home/my-app"
cp "$hello" "$home/my-app/app.c"
cp "$root/examples/consumer/CMakeLists.txt" "$root/examples/consumer/main.cpp" "$home/my-app/"
# a scratch HOME, with cargo and rustup still where they are
scratch_home=(env -u PKG_CONFIG_PATH -u LD_LIBRARY_PATH "HOME=$home"
  "CARGO_HOME=${CARGO_HOME:-$HOME/.cargo}" "RUSTUP_HOME=${RUSTUP_HOME:-$HOME/.rustup}")
echo "-- in the checkout:"
echo "$checkout_lines"
(cd "$root" && "${scratch_home[@]}" bash -euo pipefail -c "$checkout_lines")
test -f "$home/.local/include/raddiff/raddiff.hpp" || fail "the README's install put no raddiff.hpp into \$HOME/.local"
echo "-- in the project:"
echo "$project_lines"
(cd "$home/my-app" && "${scratch_home[@]}" bash -euo pipefail -c "$project_lines")
test -x "$home/my-app/build/consumer_shared" || fail "the README's CMake lines built no consumer"

step="(c) installing into another prefix reuses the build"
log="$tmp/second-install.log"
bash "$root/scripts/install.sh" "$tmp/another-prefix" > "$log" 2>&1 || { cat "$log"; fail "second install failed"; }
if grep -q "Compiling raddiff" "$log"; then cat "$log"; fail "installing into a second prefix rebuilt raddiff"; fi
if grep -q "^note:" "$log"; then cat "$log"; fail "the install printed a note"; fi
step="done"
