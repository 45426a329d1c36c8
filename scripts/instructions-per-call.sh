#!/usr/bin/env bash
# Instructions per call of one profiled case, by callgrind: runs BINARY twice with VAR set to SPEC,
# whose "{calls}" stands for the number of calls, at 2N and N calls, and prints
# (instructions(2N) - instructions(N)) / N, so that start-up and one-time set-up cancel. Exact
# counts: the load of the machine does not change them.
#
#   scripts/instructions-per-call.sh target/release/deps/kernels_regimes-* \
#       RADDIFF_REGIMES_PROFILE 'generic,hessian,{calls}' [N]
#
# The bench binaries' profile variables: RADDIFF_REGIMES_PROFILE and RADDIFF_REGIMES_MIX
# (benches/kernels_regimes.rs), RADDIFF_FORM_FACTOR_PROFILE (benches/form_factor.rs),
# RADDIFF_C_ABI_PROFILE (benches/c_abi.rs).
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,12p' "$0"
  exit 2
fi
binary=$1 var=$2 spec=$3 n=${4:-1000}
command -v valgrind >/dev/null || { echo "valgrind is not installed" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
count() {
  env "$var=${spec//\{calls\}/$1}" valgrind --tool=callgrind --callgrind-out-file="$out/cg.$1" \
    "$binary" >/dev/null 2>"$out/log.$1" || { cat "$out/log.$1" >&2; exit 1; }
  sed -n 's/^summary: //p' "$out/cg.$1"
}
high=$(count $((2 * n)))
low=$(count "$n")
echo $(((high - low) / n))
