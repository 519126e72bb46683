#!/bin/bash
# scripts/gpu-bundle/run.sh: times nimbus's OpenCL path tracer on a borrowed GPU machine (issue 13:
# the path tracer "on any OpenCL GPU where present"; when a task is lent a GPU, its kernels are
# measured there). Needs the bundle in .gpu/ (scripts/gpu-bundle/make_bundle.sh, built on Debian 12)
# and nothing installed on the device but its driver. Through the device tool, from the repository
# root: command `NB_BUDGET_S=420 bash scripts/gpu-bundle/run.sh`, carry [".gpu"], timeout_s 480;
# $OUT (default /tmp/gpuout) gets the log, the gtest output and XML, GPU load samples and a render.
# Figures of the first run: docs/benchmarks.md and docs/pathtracer.md ("On a GPU").
#   NB_BUDGET_S=470                 the whole script's deadline in seconds; every step is cut to fit
#   NB_TEST_ICD=/path/libpocl.so.2  use that OpenCL driver instead of searching for NVIDIA's (a local
#                                   rehearsal of the script on PoCL's CPU device)
#   NB_TINY=1                       tiny sample counts (default 1 when NB_TEST_ICD is set)
set -u
OUT=${OUT:-/tmp/gpuout}
mkdir -p "$OUT"
exec > >(tee -a "$OUT/log") 2>&1
T0=$(date +%s)
BUDGET=${NB_BUDGET_S:-470}
DEADLINE=$((T0 + BUDGET))
TINY=${NB_TINY:-0}
[ -n "${NB_TEST_ICD:-}" ] && TINY=${NB_TINY:-1}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$REPO"
GPU=$REPO/.gpu
BIN=$GPU/bin
NB=/opt/nb

# step NAME SECONDS CMD...: CMD under timeout (cut to the time left), its date and elapsed seconds.
step() {
    local name=$1 max=$2
    shift 2
    local now left
    now=$(date +%s)
    left=$((DEADLINE - now))
    [ "$max" -gt "$left" ] && max=$left
    if [ "$max" -lt 5 ]; then
        echo "=== $name: SKIPPED, $left s left of the ${BUDGET} s budget"
        return 99
    fi
    echo "=== $name: start $(date -u +%T) (t=$((now - T0)) s, timeout ${max} s): $*"
    local s e rc
    s=$(date +%s.%N)
    if [ -n "${STEP_OUT:-}" ]; then
        timeout -k 5 "$max" "$@" >"$STEP_OUT" 2>&1
    else
        timeout -k 5 "$max" "$@"
    fi
    rc=$?
    e=$(date +%s.%N)
    echo "=== $name: rc=$rc$([ $rc = 124 ] && echo ' TIMED OUT') after $(awk "BEGIN{printf \"%.1f\", $e - $s}") s (end $(date -u +%T), t=$(($(date +%s) - T0)) s)"
    return $rc
}

echo "=== run.sh: $(date -u) repo $REPO OUT $OUT tiny=$TINY budget ${BUDGET} s"
uname -a; grep PRETTY_NAME /etc/os-release; ldd --version | head -1; echo "$(nproc) CPUs"; free -g 2>/dev/null | head -2

# --- the bundle: libraries and PNanoVDB.h -------------------------------------------------------
mkdir -p $NB
if command -v xz >/dev/null; then
    step unpack 90 tar -xJf "$GPU/libs.tar.xz" -C $NB
else  # no xz binary: Python's tarfile reads .xz
    step unpack 90 python3 -c "import tarfile,sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$GPU/libs.tar.xz" $NB
fi || { echo "FATAL: cannot unpack .gpu/libs.tar.xz"; exit 1; }
echo "$(ls $NB/lib | wc -l) libraries in $NB/lib, $(du -sh $NB/lib | cut -f1); stand-ins (stubs): $(cat $NB/STUBS 2>/dev/null | tr '\n' ' ')"
# The PNanoVDB kernel variant reads the header from its compiled-in Debian path.
PNANO=$(cat $NB/data/PNANOVDB_PATH)
# Always Debian's (the kernel variant is written for NanoVDB 32.x's), whatever may be there.
if ! cmp -s "$PNANO" $NB/data/PNanoVDB.h; then
    [ -f "$PNANO" ] && echo "replacing a different $PNANO"
    mkdir -p "$(dirname "$PNANO")" && cp $NB/data/PNanoVDB.h "$PNANO"
fi
echo "PNanoVDB.h at $PNANO: $(cmp -s "$PNANO" $NB/data/PNanoVDB.h && echo Debian\'s)"
# Tests, benches and the CLI have the checkout's path compiled in (kernels, shaders, test data):
# make_bundle.sh records it (the first bundle did not: /work/main).
SRC=$(cat "$GPU/SOURCE_DIR" 2>/dev/null)
SRC=${SRC:-/work/main}
if [ ! -e "$SRC" ]; then
    mkdir -p "$(dirname "$SRC")" && ln -s "$REPO" "$SRC" && echo "linked $SRC -> $REPO"
elif [ "$(cd "$SRC" && pwd -P)" != "$(pwd -P)" ]; then
    echo "NOTE: the binaries read test data and shaders from $SRC, not from this checkout"
fi

# --- the OpenCL driver --------------------------------------------------------------------------
echo "=== /usr/local/nvidia:"; ls -la /usr/local/nvidia /usr/local/nvidia/lib* 2>&1 | grep -iE "opencl|nvidia-ml|libcuda|^/|total" | head -20
echo "=== /etc/OpenCL/vendors:"; ls -la /etc/OpenCL/vendors 2>&1; cat /etc/OpenCL/vendors/*.icd 2>/dev/null; echo
if [ -n "${NB_TEST_ICD:-}" ]; then
    ICD=$NB_TEST_ICD
    echo "TEST MODE: OpenCL driver $ICD instead of NVIDIA's"
else
    : >"$OUT/icd_candidates.txt"
    timeout 20 find /usr/local/nvidia \( -name 'libnvidia-opencl.so*' \) 2>/dev/null >>"$OUT/icd_candidates.txt"
    timeout 40 find / -xdev \( -name 'libnvidia-opencl.so*' \) 2>/dev/null >>"$OUT/icd_candidates.txt"
    echo "libnvidia-opencl candidates:"; cat "$OUT/icd_candidates.txt"
    # Prefer the .so.1 name (what the ICD files of NVIDIA's packages name), else the versioned file.
    # (the /usr/local/nvidia mount first: its driver matches the kernel module)
    ICD=
    for pat in '\.so\.1$' 'libnvidia-opencl\.so\.[0-9]' '.'; do
        for c in $(grep "$pat" "$OUT/icd_candidates.txt"); do
            if [ -z "$ICD" ] && [ -e "$c" ]; then ICD=$c; fi
        done
    done
fi
if [ -z "$ICD" ] || [ ! -e "$ICD" ]; then
    echo "FATAL: NO NVIDIA OpenCL driver (libnvidia-opencl.so*) found on this machine."
    echo "--- /usr/local/nvidia/lib*:"; ls -la /usr/local/nvidia/lib* 2>&1 | head -80
    echo "--- /etc/OpenCL:"; ls -laR /etc/OpenCL 2>&1
    echo "--- libcuda/libnvidia anywhere:"; timeout 30 find / -xdev -name 'libcuda.so*' -o -name 'libnvidia-*.so*' 2>/dev/null | head -30
    exit 3
fi
mkdir -p $NB/icd
echo "$ICD" >$NB/icd/nvidia.icd
export OCL_ICD_VENDORS=$NB/icd
export LD_LIBRARY_PATH=$NB/lib:$(dirname "$ICD")
export NIMBUS_KERNEL_DIR=$REPO/kernels
export NIMBUS_CACHE_DIR=/tmp/nbcache
mkdir -p $NIMBUS_CACHE_DIR
echo "ICD $ICD; OCL_ICD_VENDORS=$OCL_ICD_VENDORS; LD_LIBRARY_PATH=$LD_LIBRARY_PATH"
echo "NIMBUS_KERNEL_DIR=$NIMBUS_KERNEL_DIR NIMBUS_CACHE_DIR=$NIMBUS_CACHE_DIR NIMBUS_DEVICE=${NIMBUS_DEVICE:-<unset: the first GPU>}"

# --- do the bundled libraries suffice? ------------------------------------------------------------
for b in nimbus bench_pathtrace test_pathtracer; do
    miss=$(ldd -r "$BIN/$b" 2>&1 | grep -E "not found|undefined symbol")
    if [ -n "$miss" ]; then echo "ldd $b: MISSING:"; echo "$miss"; else echo "ldd -r $b: every library and symbol found"; fi
done
ldd "$BIN/nimbus" | grep -E "libstdc|libc\.so|libOpenCL|libgcc_s"
echo "glibc here: $(ldd --version | head -1 | awk '{print $NF}'); the bundle needs GLIBC up to $(cat $NB/GLIBC_MAX 2>/dev/null), GLIBCXX up to $(cat $NB/GLIBCXX_MAX 2>/dev/null)"
grep -aoE 'GLIBCXX_3\.4\.[0-9]+' "$(ldd "$BIN/nimbus" | awk '/libstdc\+\+/{print $3}')" 2>/dev/null | sort -u | sort -V | tail -1 | sed 's/^/libstdc++ here has up to /'

NSMI=$(command -v nvidia-smi || ls /usr/local/nvidia/bin/nvidia-smi 2>/dev/null)
[ -n "$NSMI" ] && step nvidia-smi 20 "$NSMI" -L
STEP_OUT=$OUT/devices.txt step devices 60 "$BIN/nimbus" devices
DEV_RC=$?
cat "$OUT/devices.txt"
grep -q GPU "$OUT/devices.txt" || echo "WARNING: no GPU among the OpenCL devices"
if [ $DEV_RC != 0 ] || grep -q "no OpenCL device" "$OUT/devices.txt"; then
    echo "FATAL: nimbus sees no OpenCL device. Diagnostics:"
    echo "--- ldd $ICD:"; ldd "$ICD" 2>&1 | head -20
    echo "--- without RTLD_DEEPBIND:"; NIMBUS_OPENCL_NO_DEEPBIND=1 timeout 60 "$BIN/nimbus" devices
    echo "--- the loader's search (LD_DEBUG=libs):"; LD_DEBUG=libs timeout 60 "$BIN/nimbus" devices 2>&1 | grep -vE "search path=|trying file=|search cache=" | grep -iE "opencl|nvidia|cuda|error|cannot|fatal" | head -40
    echo "--- OCL_ICD_DEBUG=7:"; OCL_ICD_DEBUG=7 timeout 60 "$BIN/nimbus" devices 2>&1 | tail -30
    exit 4
fi

# --- the measurements -----------------------------------------------------------------------------
if [ "$TINY" = 1 ]; then
    GTEST_FILTER='DeviceSelection.*:KernelBuild.*:LaunchSize*.*:DeviceGrid.*'
    L="1 32"; LR=1; NS="1 32"; NR=1; PS="2 32"; WS=4; WR="[32,32]"; BIG="[64,64]"; BIGSPP=1
else
    GTEST_FILTER='*'
    L="64 128"; LR=4; NS="16 128"; NR=5; PS="64 128"; WS=1024; WR=""; BIG="[1024,1024]"; BIGSPP=64
fi
# a. the path tracer's tests on the device (NIMBUS_DEVICE unset: the first GPU)
STEP_OUT=$OUT/a_gtest.txt step a_gtest 150 "$BIN/test_pathtracer" --gtest_brief=1 --gtest_filter="$GTEST_FILTER" \
    --gtest_output=xml:"$OUT/test_pathtracer.xml"
echo "--- a_gtest (last 40 lines of $OUT/a_gtest.txt):"; tail -40 "$OUT/a_gtest.txt"

# b. the launch: the runtime's work-group size against the chosen one (128x128 pixels: the bench's
# second argument is the cloud's voxel resolution, not the image's), GPU load sampled meanwhile.
UTIL_PID=
if [ -n "$NSMI" ]; then
    "$NSMI" --query-gpu=timestamp,utilization.gpu,memory.used --format=csv,noheader -lms 250 >"$OUT/util_b_launch.csv" 2>&1 &
    UTIL_PID=$!
fi
step b_launch 45 "$BIN/bench_pathtrace" $L "" launch $LR
[ -n "$UTIL_PID" ] && kill "$UTIL_PID" 2>/dev/null
[ -n "$UTIL_PID" ] && { echo "GPU utilization during b_launch (% samples):"; awk -F', ' '{print $2}' "$OUT/util_b_launch.csv" | tr '\n' ' '; echo; }
# b2. a launch that can fill the GPU: the default scene at 1024x1024 (the bench's image is fixed at 128x128)
step b2_default_big 50 "$BIN/nimbus" render --default --method pathtrace --set "camera.resolution=$BIG" \
    --set render.spp=$BIGSPP --set render.time_limit=40 -o /tmp/nb_default_big.exr --preview "" --explain
echo "(b2: $(echo "$BIG" | tr -d '[]' | awk -F, '{print $1*$2}') pixels x $BIGSPP spp path samples in the step's time above, kernel build and the cloud's generation included)"

# c. brick pool against PNanoVDB
step c_pnanovdb 60 "$BIN/bench_pathtrace" $NS "" pnanovdb $NR
# d. the majorant grid against one global majorant (dense, then wispy)
step d_majorant_dense 30 "$BIN/bench_pathtrace" $PS ""
step d_majorant_wispy 30 "$BIN/bench_pathtrace" $PS "" wispy
# e. a validation scene at 1024 spp through the CLI, with tests/validation/test_references.py's
# settings (seed 7, which the shipped reference did not use; equi-angular sampling off, as the
# reference was made), so that its per-pixel z and energy checks apply to the render as they stand.
# (The first run, 2026-12-04, used the scene's seed 1 and equi-angular sampling: docs/pathtracer.md.)
step e_wisps 60 "$BIN/nimbus" render tests/validation/validation/wisps_point_lit.json --method pathtrace \
    --set render.spp=$WS --set render.time_limit=45 --set render.seed=7 --set render.equiangular=false \
    ${WR:+--set "camera.resolution=$WR"} -o "$OUT/wisps_point_lit_pt.exr" \
    --preview "$OUT/wisps_point_lit_pt.png" --explain
ls -la "$OUT"
echo "=== run.sh done: $(date -u), $(($(date +%s) - T0)) s"
