#!/usr/bin/env bash
# Builds nimbus and runs the benchmarks, writing their figures into docs/benchmarks.md.
# The machine should be otherwise idle; timings are ratios taken side by side in one run.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
for b in build/tests/bench/bench_*; do
  [ -x "$b" ] || continue
  echo "== $b"
  case "$(basename "$b")" in
    bench_single_vs_vdb_render) "$b" build/bin/nimbus docs/benchmarks.md ;;
    *) "$b" docs/benchmarks.md ;;
  esac
done
