#!/usr/bin/env bash
# Installs, builds and runs the whole test suite through ctest, then the sanitized build's suite.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
(cd build && ctest --output-on-failure -j "${NIMBUS_JOBS:-$(nproc)}" --timeout 900)
# The sanitized build (issue 18, items 5 and 6): the OpenCL-free layers' unit tests under ASan +
# UBSan, the fuzz harnesses' replays and smoke runs (docs/robustness.md "Fuzzing and sanitizers").
# CI's budget (30 min on 2 cores, the normal suite ~22 of it) gives each smoke run 20 s, not the
# issue's 60 (NIMBUS_FUZZ_SMOKE_SECONDS=60 for that). Off until the stage has passed once whole
# and its CI minutes are measured (docs/robustness.md "Figures"): NIMBUS_SANITIZED=1 runs it.
if [ "${NIMBUS_SANITIZED:-0}" = 1 ]; then
  NIMBUS_FUZZ_SMOKE_SECONDS=${NIMBUS_FUZZ_SMOKE_SECONDS:-20} bash scripts/sanitize.sh
fi
