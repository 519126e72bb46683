#!/usr/bin/env bash
# The sanitized build and its tests (issue 18, items 5 and 6; docs/robustness.md "Fuzzing and
# sanitizers"): build-san/, clang with AddressSanitizer + UndefinedBehaviorSanitizer and
# libFuzzer's coverage, holding the fuzz harnesses (tests/fuzz) and the unit tests of the
# OpenCL-free layers (tests/sanitized). Then runs its ctest: the sanitized unit tests, each
# harness's replay of its findings and seeds, and each harness's smoke run.
#
#   scripts/sanitize.sh [ctest arguments]    e.g. -L '^san_' (unit tests only), -R fuzz.vdb
#   NIMBUS_JOBS=1                            build and test jobs (default: nproc)
#   NIMBUS_FUZZ_SMOKE_SECONDS=60             seconds of each harness's smoke run
#   NIMBUS_SANITIZED_TARGETS="san_core fuzz_vdb ..."
#                                            build only these targets (san_<area> unit tests,
#                                            fuzz_<name> harnesses) and run only their tests
#                                            (default: all); scripts/test.sh (CI) names its part
#
# scripts/test.sh (CI) runs it after the normal suite; scripts/fuzz.sh runs the harnesses long.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

bash scripts/install-deps.sh >/dev/null

# The same ccache as build.sh: the sanitized objects are cached beside the normal ones.
export CCACHE_BASEDIR=$root
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
# -g objects: ccache would hash the build folder into the key (its hash_dir default), so a fresh
# clone (CI's) would miss every object; the debug info's paths are all that differ.
export CCACHE_NOHASHDIR=1

jobs=${NIMBUS_JOBS:-$(nproc)}
cmake -S . -B build-san -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DNIMBUS_SANITIZE=ON \
  -DNIMBUS_FUZZ_SMOKE_SECONDS="${NIMBUS_FUZZ_SMOKE_SECONDS:-60}" >/dev/null
targets=(${NIMBUS_SANITIZED_TARGETS:-})
if [ ${#targets[@]} -gt 0 ]; then
  cmake --build build-san -j "$jobs" --target "${targets[@]}"
  # Each test is labelled with its target (tests/sanitized, tests/fuzz).
  labels=$(IFS='|'; echo "${targets[*]}")
  cd build-san
  ctest --output-on-failure -j "$jobs" --timeout 900 -L "^($labels)\$" "$@"
else
  cmake --build build-san -j "$jobs"
  cd build-san
  ctest --output-on-failure -j "$jobs" --timeout 900 "$@"
fi
