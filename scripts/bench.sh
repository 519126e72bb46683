#!/usr/bin/env bash
# Builds nimbus and runs the benchmarks, writing their figures into docs/benchmarks.md (each
# into its own <!-- bench:NAME --> section). The machine should be otherwise idle; timings are
# ratios taken side by side in one run.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
report=docs/benchmarks.md
bench=build/tests/bench

# Replaces section NAME of the report with standard input.
section() {
  python3 - "$report" "$1" <<'PY'
import sys
path, name = sys.argv[1], sys.argv[2]
body = sys.stdin.read()
text = open(path).read()
begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
block = f"{begin}\n{body}{end}"
a, b = text.find(begin), text.find(end)
text = text[:a] + block + text[b + len(end):] if a >= 0 and b > a else text.rstrip("\n") + "\n\n" + block + "\n"
open(path + ".tmp", "w").write(text)
import os; os.replace(path + ".tmp", path)
PY
}

echo "== single vs vdb_render"
"$bench/bench_single_vs_vdb_render" build/bin/nimbus "$report"
echo "== wkb vs single"
build/tests/wkb/bench_wkb "$report"
echo "== scene geometry: single and wkb with and without a 100k-triangle occluder"
"$bench/bench_geometry" "$report"
echo "== deep output (issue 14, item 5): single and wkb without and with output.deep"
"$bench/bench_deep" "$report"
echo "== sky (issue 17)"
"$bench/bench_sky" "$report"
echo "== role grid resample (issue 18): nimbus's active-region walk against OpenVDB's resampler"
"$bench/bench_resample" "$report"
echo "== path tracer: samples per second with and without the majorant grid"
{
  echo "PoCL on this machine's CPU cores unless a GPU is present; 128x128 pixels, 16 spp, a 128^3 cloud."
  echo '```'
  build/tests/pathtracer/bench_pathtrace 16 128 "" dense
  build/tests/pathtracer/bench_pathtrace 16 128 "" wispy
  echo '```'
} | section pathtrace
echo "== path tracer: the launch configuration (runtime's work-group size against the chosen one)"
{
  echo "PoCL on this machine's CPU cores unless a GPU is present; 128x128 pixels, 64 spp, the dense 128^3 cloud, max_depth unbounded; rounds interleaved."
  echo '```'
  build/tests/pathtracer/bench_pathtrace 64 128 "" launch 5
  echo '```'
} | section pathtrace-launch
echo "== path tracer: density lookups through the brick pool against PNanoVDB (issue 17, item 10)"
{
  echo "PoCL on this machine's CPU cores unless a GPU is present; 128x128 pixels, 16 spp, max_depth 64; rounds interleaved after one warm-up render of each."
  echo '```'
  build/tests/pathtracer/bench_pathtrace 16 128 "" pnanovdb 9
  echo '```'
} | section pathtrace-pnanovdb
echo "== sequences: --frames in one process against a process per frame"
/usr/bin/python3 tests/bench/bench_sequence.py build/bin/nimbus 12 2 | section sequence
echo "== path tracer against Cycles: noise at equal time (skipped without blender; ~30 min with fresh references)"
"$bench/bench_pathtrace_vs_cycles" build/bin/nimbus "$report"
echo "== path tracer: equi-angular sampling towards point lights, without and with, at equal time (~6 min)"
"$bench/bench_equiangular" "$report"
