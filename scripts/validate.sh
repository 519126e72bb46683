#!/usr/bin/env bash
# validate.sh: runs `nimbus compare` on every scene in tests/compare/scenes/ and prints the
# Markdown table of docs/validation.md (scene, model, kernel, L2plus energy error, beauty
# relMSE, WKB time, path-tracer time to equal error).
#
#   scripts/validate.sh [NIMBUS_BINARY] [OUT_DIR] [extra compare flags...]
#   e.g. scripts/validate.sh build-cmp/bin/nimbus /tmp/validation --minutes 1 --seeds 2
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
nimbus="${1:-$here/build/bin/nimbus}"
out="${2:-/tmp/nimbus-validation}"
shift $(( $# > 2 ? 2 : $# )) || true
mkdir -p "$out"
for scene in "$here"/tests/compare/scenes/*.json; do
  name="$(basename "$scene" .json)"
  echo "== $name" >&2
  "$nimbus" compare "$scene" --out "$out/$name" -q "$@"
done
python3 - "$out" "$here/tests/compare/scenes" <<'PY'
import csv, json, os, sys
out, scenes = sys.argv[1], sys.argv[2]
print("| scene | tau | albedo | g | view | model | kernel | L2plus energy err | L2plus meanRel | beauty energy err "
      "| beauty relMSE | WKB s | PT s to equal beauty relMSE | PT relMSE @8s (ref floor) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for f in sorted(os.listdir(scenes)):
    name = f[:-5]
    path = os.path.join(out, name, "compare.csv")
    if not os.path.exists(path):
        continue
    s = json.load(open(os.path.join(scenes, f)))
    m = s["volumes"][0]["medium"]
    st = m["sigma_s"] + m["sigma_a"]
    tau = 2 * st * s["volumes"][0]["source"].get("radius", 1.0)
    alb = m["sigma_s"] / st
    g = m["phase"]["g"]
    view = {"lit": "lit side", "shadow": "shadowed side", "against": "against light"}[
        "lit" if name.endswith("lit") else "shadow" if "shadow" in name or "side" in name else "against"]
    rows = list(csv.DictReader(open(path)))
    pt = [r for r in rows if r["method"] == "pathtrace" and r["label"].startswith("t=")]
    last = max(float(r["seconds"]) for r in pt)
    ptlast = [float(r["beauty_relmse"]) for r in pt if float(r["seconds"]) >= 0.5 * last]
    floor = ""
    summ = open(os.path.join(out, name, "summary.md")).read()
    if "its own beauty relMSE" in summ:
        floor = summ.split("its own beauty relMSE (from its variance) ")[1].split(",")[0]
    for r in rows:
        if r["method"] != "wkb" or r["label"] != "base":
            continue
        print(f"| {name} | {tau:g} | {alb:.3g} | {g:g} | {view} | {r['source']} | {r['kernel']} | "
              f"{float(r['L2plus_energyrel']):+.3f} | {float(r['L2plus_meanrel']):.3f} | {float(r['beauty_energyrel']):+.3f} | "
              f"{float(r['beauty_relmse']):.4f} | {float(r['seconds']):.2f} | {float(r['pt_seconds_to_equal_beauty_relmse']):.3g} | "
              f"{sum(ptlast)/len(ptlast):.4f} ({floor}) |")
PY
