#!/usr/bin/env bash
# Coverage-guided fuzzing of the C entry points with AFL++ through cargo-afl (docs/fuzzing.md).
#
#   scripts/fuzz.sh TARGET SECONDS [OUTPUT_DIR]   one target (kernels, radii, gather_evaluate,
#                                                  cache_ops, cache_load, cache_irradiance,
#                                                  single_scatter)
#   scripts/fuzz.sh all SECONDS                    every target, SECONDS each, one after another
#
# Starts from fuzz/corpus/TARGET, writes AFL++'s state to OUTPUT_DIR (default
# $CARGO_TARGET_DIR/afl/TARGET or target/afl/TARGET, started afresh), prints the run's executions,
# coverage and findings, and exits 1 when AFL++ found a crash (a failed property: the harness
# panics) or a hang (no answer within FUZZ_TIMEOUT_MS, default 10000). Findings are listed; keep
# each as fuzz/regressions/TARGET/NAME so that `cargo test --test fuzz_regressions` replays it.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
targets=(kernels radii gather_evaluate cache_ops cache_load cache_irradiance single_scatter)

if [ $# -lt 2 ]; then
  sed -n '2,12p' "$0" >&2
  exit 2
fi
target=$1 seconds=$2
if [ "$target" = all ]; then
  status=0
  for t in "${targets[@]}"; do "$0" "$t" "$seconds" || status=1; done
  exit $status
fi
case " ${targets[*]} " in *" $target "*) ;; *) echo "unknown target $target" >&2; exit 2 ;; esac

bash scripts/ensure-fuzz.sh
target_dir=${CARGO_TARGET_DIR:-$root/target}/fuzz
out=${3:-$target_dir/afl/$target}
# The fuzz crate is its own workspace: its own target directory, so that the instrumented build
# never invalidates the root's.
(cd fuzz && CARGO_TARGET_DIR=$target_dir cargo afl build --release --features afl --bin "$target" -q)
rm -rf "$out"
mkdir -p "$(dirname "$out")"

# Containers and shared CI machines: no CPU frequency governor, no core dump handler of AFL++'s
# liking, no free core to bind to, no terminal.
export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_AFFINITY=1 AFL_NO_UI=1
export AFL_FAST_CAL=1 AFL_QUIET=1
echo "== fuzz $target for ${seconds}s (AFL++ via cargo-afl; corpus fuzz/corpus/$target)"
cargo afl fuzz -V "$seconds" -t "${FUZZ_TIMEOUT_MS:-10000}" -i "fuzz/corpus/$target" -o "$out" \
  "$target_dir/release/$target" >"$out.log" 2>&1 || {
  echo "afl-fuzz failed; its log ($out.log):" >&2
  tail -40 "$out.log" >&2
  exit 1
}

stats=$out/default/fuzzer_stats
field() { awk -F' *: *' -v k="$1" '$1 == k { print $2 }' "$stats"; }
echo "   $(field execs_done) executions in $(field run_time)s ($(field execs_per_sec)/s)," \
  "corpus $(field corpus_count) inputs, edges $(field edges_found)/$(field total_edges)" \
  "($(field bitmap_cvg)), crashes $(field saved_crashes), hangs $(field saved_hangs)"
findings=$(find "$out/default/crashes" "$out/default/hangs" -type f ! -name README.txt 2>/dev/null)
if [ -n "$findings" ]; then
  echo "FINDINGS for $target (replay: cd fuzz && cargo run --release --bin replay -- $target FILE):" >&2
  echo "$findings" >&2
  exit 1
fi
