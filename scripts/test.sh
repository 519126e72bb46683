#!/usr/bin/env bash
# Installs, builds and runs the whole test suite through ctest, then the sanitized build's suite.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/build.sh
(cd build && ctest --output-on-failure -j "${NIMBUS_JOBS:-$(nproc)}" --timeout 900)
# The sanitized build (issue 18, items 5 and 6): the OpenCL-free layers' unit tests under ASan +
# UBSan, the fuzz harnesses' replays and smoke runs (docs/robustness.md "Fuzzing and sanitizers").
bash scripts/sanitize.sh
