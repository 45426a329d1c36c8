#!/usr/bin/env bash
# Makes `cargo cinstall` available: does nothing when it is, otherwise
# `cargo install cargo-c --locked` (several minutes of compiling). The newest cargo-c may need a newer
# Rust than the one installed (cargo-c 0.10.26 needs 1.97); then the newest one known to build
# with Rust 1.95 (0.10.24) is installed instead.
set -euo pipefail
if cargo cinstall --help >/dev/null 2>&1; then
  exit 0
fi
# Building cargo-c links OpenSSL through pkg-config (Debian: pkg-config libssl-dev).
missing=()
command -v pkg-config >/dev/null || missing+=(pkg-config)
if command -v dpkg >/dev/null && ! dpkg -s libssl-dev >/dev/null 2>&1; then missing+=(libssl-dev); fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
  else
    echo "building cargo-c needs: ${missing[*]} (Debian/Ubuntu: sudo apt-get install ${missing[*]})" >&2
  fi
fi
echo "cargo cinstall missing: cargo install cargo-c --locked"
if ! cargo install cargo-c --locked; then
  echo "the newest cargo-c does not build with $(rustc --version): trying cargo-c 0.10.24"
  cargo install cargo-c --locked --version 0.10.24
fi
cargo cinstall --help >/dev/null
