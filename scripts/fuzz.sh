#!/usr/bin/env bash
# Long fuzz runs of the libFuzzer harnesses (tests/fuzz; issue 18, item 5), for the figures in
# docs/robustness.md "Fuzzing and sanitizers".
#
#   scripts/fuzz.sh [--time SECONDS | --runs N] [--jobs J] [HARNESS...] [-- LIBFUZZER OPTIONS]
#
#   HARNESS     scene vdb nvdb mesh depth envmap (default: all)
#   --time S    stop each harness after S seconds (default 3600)
#   --runs N    stop each harness after N executions instead (e.g. 1000000)
#   --jobs J    harnesses run at once (default NIMBUS_JOBS or 1), each on one core
#   (-- -fork=2: libFuzzer's fork mode, two jobs on one corpus counted as one run; the 10^6 runs
#   of nvdb, whose inputs load whole grids, in session 32)
#   --fast      UBSan only (no ASan, no leak check), built in build-fuzz: for the 10^6-execution
#               runs of harnesses whose inputs allocate large buffers (Assimp's OBJ reader takes a
#               zeroed 16 MiB buffer per file, which ASan maps and unmaps each time: from the
#               seeds, mesh 142 -> 3000 exec/s, vdb 60 -> 666); crashes, UBSan reports, hangs
#               and memory limits are still findings, leaks and silent heap errors are not
#
# Builds the sanitized build (BUILD: build-san, as scripts/sanitize.sh; build-fuzz with --fast)
# first. Each harness grows its corpus in BUILD/fuzz/corpus/<name> (starting from the seeds,
# tests/fuzz/corpus/<name>, and the saved findings, tests/fuzz/regressions/<name>); a crash, leak,
# timeout or out-of-memory input is saved as BUILD/fuzz/artifacts/<name>-crash-<sha1> (or leak-,
# timeout-, oom-) and stops that harness. The log is BUILD/fuzz/<name>.log; the last lines printed are one
# summary row per harness: executions, exec/s, coverage (edges, features), corpus, peak RSS,
# findings. A finding becomes a regression: copy it to tests/fuzz/regressions/<name>/ (a short
# descriptive name), fix the code, and the replay tests (fuzz.<name>.replay in build-san,
# fuzz_regressions.<name> through the nimbus binary) keep it fixed.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

all=(scene vdb nvdb mesh depth envmap)
stop=(-max_total_time=3600)
jobs=${NIMBUS_JOBS:-1}
build=build-san
sanitizers=address,undefined
harnesses=()
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --time) stop=(-max_total_time="$2"); shift 2 ;;
    --runs) stop=(-runs="$2"); shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --fast) build=build-fuzz; sanitizers=undefined; shift ;;
    --) shift; extra=("$@"); break ;;
    -h|--help) sed -n '2,27p' "$0"; exit 0 ;;
    *) harnesses+=("$1"); shift ;;
  esac
done
[ ${#harnesses[@]} -gt 0 ] || harnesses=("${all[@]}")
for h in "${harnesses[@]}"; do
  [[ " ${all[*]} " == *" $h "* ]] || { echo "fuzz.sh: unknown harness '$h' (${all[*]})" >&2; exit 2; }
done

bash scripts/install-deps.sh >/dev/null
export CCACHE_BASEDIR=$root
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
# -g objects: ccache would hash the build folder into the key (its hash_dir default), so a fresh
# clone (CI's) would miss every object; the debug info's paths are all that differ.
export CCACHE_NOHASHDIR=1
cmake -S . -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DNIMBUS_SANITIZE=ON \
  -DNIMBUS_SANITIZERS="$sanitizers" >/dev/null
cmake --build "$build" -j "${NIMBUS_JOBS:-$(nproc)}" --target "${harnesses[@]/#/fuzz_}"

out=$root/$build/fuzz
mkdir -p "$out/artifacts"

run() {
  local h=$1 corpus=$out/corpus/$1
  mkdir -p "$corpus"
  local dirs=("$corpus" "tests/fuzz/corpus/$h")
  [ -d "tests/fuzz/regressions/$h" ] && dirs+=("tests/fuzz/regressions/$h")
  # -timeout and -rss_limit_mb as the smoke runs (tests/fuzz/CMakeLists.txt).
  local code=0
  "$build/tests/fuzz/fuzz_$h" -timeout=25 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/artifacts/$h-" "${stop[@]}" "${extra[@]}" "${dirs[@]}" >"$out/$h.log" 2>&1 || code=$?
  echo "$code" >"$out/$h.status"
}

# One summary row from a log: libFuzzer's final stats and its last status line.
summary() {
  local h=$1 log=$out/$1.log code=$2
  local execs rate rss last cov ft corp found
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9]*[a-zA-Z]*\).*/\1/p' <<<"$last")
  # -fork=N (libFuzzer's fork mode: N jobs on one corpus, one run's count) prints no final stats:
  # its executions from its last line, its corpus as a file count, its rate from its time.
  if [ -z "$execs" ] && grep -q '^INFO: fuzzed for' "$log"; then
    execs=$(sed -n 's/^INFO: fuzzed for \([0-9]*\) iterations.*/\1/p' "$log" | tail -1)
    corp=$(sed -n 's/.* corp: \([0-9]*\) exec.*/\1/p' <<<"$last")
    local secs
    secs=$(sed -n 's/^INFO: exiting: .* time: \([0-9]*\)s.*/\1/p' "$log" | tail -1)
    [ -n "$secs" ] && [ "$secs" -gt 0 ] && rate=$((execs / secs))
  fi
  found=$(find "$out/artifacts" -name "$h-*" | wc -l)
  printf '%-7s exit %-3s executions %-10s exec/s %-6s cov %-6s ft %-7s corpus %-12s peak RSS %-5s MB  findings %s\n' \
    "$h" "$code" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "${rss:-?}" "$found"
}

running=0
for h in "${harnesses[@]}"; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  echo "fuzz.sh: $h (${stop[*]} ${extra[*]}) -> $out/$h.log"
  rm -f "$out/$h.status"
  run "$h" &
  running=$((running + 1))
done
wait
failed=0
for h in "${harnesses[@]}"; do
  code=$(cat "$out/$h.status" 2>/dev/null || echo '?')
  [ "$code" = 0 ] || failed=$((failed + 1))
  summary "$h" "$code"
done
exit "$failed"
