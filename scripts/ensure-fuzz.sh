#!/usr/bin/env bash
# Makes `cargo afl` (cargo-afl, with its AFL++ built for the current rustc) available: does nothing
# when it is (well under a second), otherwise installs what a fresh Debian 12 machine lacks:
# make and a C compiler (Debian: gcc, make, libc6-dev) to build AFL++, then
# `cargo install cargo-afl --locked`, whose build script compiles the AFL++ it carries (no clang or
# LLVM needed: Rust code is instrumented by rustc's own SanitizerCoverage pass, on stable Rust).
# About 1.5 minutes on the project's 2-core machine. After a rustc update, only AFL++'s runtime is
# rebuilt (`cargo afl config --build`).
set -euo pipefail
AFL_VERSION=0.18.2

afl_runtime_ready() {
  # `config --build` refuses ("already built") when the runtime for this rustc exists.
  local out
  if out=$(cargo afl config --build 2>&1); then return 0; fi
  grep -q "already built" <<<"$out"
}

if cargo afl --version >/dev/null 2>&1; then
  afl_runtime_ready && exit 0
fi

missing=()
command -v make >/dev/null || missing+=(make)
command -v cc >/dev/null || missing+=(gcc)
if command -v dpkg >/dev/null && ! dpkg -s libc6-dev >/dev/null 2>&1; then missing+=(libc6-dev); fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
  else
    echo "building AFL++ needs: ${missing[*]} (Debian/Ubuntu: sudo apt-get install ${missing[*]})" >&2
    exit 1
  fi
fi
if ! cargo afl --version >/dev/null 2>&1; then
  echo "cargo afl missing: cargo install cargo-afl --locked --version $AFL_VERSION"
  cargo install cargo-afl --locked --version "$AFL_VERSION"
fi
afl_runtime_ready || cargo afl config --build --force
cargo afl --version >/dev/null
