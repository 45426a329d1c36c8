#!/usr/bin/env bash
# The C-ABI bench: raddiff's C entry points against the textbook formulas a C user writes
# (benches/c/), compiled as a user compiles them (cc -O2, libm) against the release static library,
# interleaved in one run. Prints a table of ns per call and ratios to the textbook value.
#
#   scripts/bench-c-abi.sh [rounds]      (default 30 rounds)
#
# The binary is left at target/bench-c-abi/bench_kernels (under $CARGO_TARGET_DIR when set), for
# callgrind:
#   scripts/instructions-per-call.sh target/bench-c-abi/bench_kernels RADDIFF_C_ABI_PROFILE \
#       'solid_angle_value,{calls}'
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --lib
target="${CARGO_TARGET_DIR:-target}"
out="$target/bench-c-abi"
mkdir -p "$out"
"${CC:-cc}" -std=c99 -D_POSIX_C_SOURCE=200809L -O2 -Wall -Wextra -Werror -pedantic -g \
  -I include benches/c/bench_kernels.c benches/c/textbook.c \
  "$target/release/libraddiff.a" -lpthread -ldl -lm -lrt -o "$out/bench_kernels"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "load average: $(cut -d' ' -f1-3 /proc/loadavg); commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
"$out/bench_kernels" "$@"
