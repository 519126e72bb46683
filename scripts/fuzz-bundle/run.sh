#!/bin/bash
# scripts/fuzz-bundle/run.sh: long libFuzzer runs of nimbus's harnesses (tests/fuzz; issue 18: "at least
# 10^6 executions per harness") on a borrowed many-core machine, all harnesses at once, each in
# libFuzzer's fork mode. Figures of the first run: docs/robustness.md, "Long runs", "16 cores on the lent
# device machine (2026-12-04)".
# The bundle lives in .fuzz/ in the repository root (git-ignored): bin.tar.xz (the stripped sanitized
# harnesses), libs.tar.xz (their libraries: .gpu's, see scripts/gpu-bundle/), extra-libs.tar.xz (if
# any) and SOURCE_DIR. Rebuild it after a sanitized build (scripts/sanitize.sh, clang 14, Debian 12):
#   bash scripts/fuzz-bundle/make.sh [BUILD_SAN]      # BUILD_SAN defaults to build-san/ in the repo root
# Through the device tool, from the repository root ($OUT is set there; 16 cores):
#   command `NB_FORKS_depth=6 NB_FORKS_envmap=6 NB_FORKS_vdb=3 NB_FORKS_mesh=1 bash scripts/fuzz-bundle/run.sh`,
#   carry [".fuzz"], timeout_s 540 (the script ends by itself at NB_BUDGET_S, default 480 s)
# Locally, as a rehearsal: NB_PREFIX=/tmp/nb OUT=/tmp/fuzzout NB_BUDGET_S=120 bash scripts/fuzz-bundle/run.sh
# The stacks in the logs are module+offset (the harnesses are stripped): symbolize them with the
# unstripped build (llvm-symbolizer --obj=build-san/tests/fuzz/fuzz_X 0xOFFSET). Stripped, LSan cannot
# name the frames, so tests/sanitized/SanitizerDefaults.cpp's suppression of OpenVDB's
# RootNode::readTopology leak does not apply here: fuzz_vdb reports that known leak as a finding.
#
# (The notes of the first version, .fuzz/run.sh:)
# .fuzz/run.sh: long libFuzzer runs of nimbus's harnesses (tests/fuzz; issue 18: "at least 10^6
# executions per harness") on a borrowed 16-core machine. From the repository root, $OUT set:
#   bash .fuzz/run.sh                    carry [".fuzz"] (bin.tar.xz, libs.tar.xz, this script)
# The harnesses are the sanitized clang build (ASan + UBSan + libFuzzer, -DNIMBUS_SANITIZE=ON, as
# scripts/fuzz.sh), built on Debian 12; their library closure is .gpu's libs.tar.xz (unpacked to
# $NB_PREFIX, default /opt/nb). All harnesses run AT ONCE, each in libFuzzer's fork mode
# (-fork=N: N child processes, one shared corpus, the parent merges and sums the executions).
#   NB_BUDGET_S=480        the whole script's deadline (every step is cut to fit)
#   NB_FUZZ_SECONDS=420    each harness's -max_total_time (cut to the deadline less a margin)
#   NB_FUZZ_FORKS=4        -fork=N for every harness; NB_FORKS_<h>=N for one (e.g. NB_FORKS_vdb=7)
#   NB_FUZZ_HARNESSES="vdb mesh depth envmap"   (scene is in the bundle too)
#   NB_FUZZ_IGNORE_CRASHES=1  keep fuzzing after a crash (its input is still saved); 0: stop that
#                          harness at its first crash, as scripts/fuzz.sh does
# $OUT gets run.log, <h>.log (the fork parent's log), summary.txt, artifacts.tar.gz (crash, leak,
# timeout, oom, slow-unit inputs; artifacts/ while running) and corpora.tar.gz (the new units).
set -u
T0=$(date +%s)
BUDGET=${NB_BUDGET_S:-480}
DEADLINE=$((T0 + BUDGET))
SECS=${NB_FUZZ_SECONDS:-420}
FORKS=${NB_FUZZ_FORKS:-4}
HARNESSES=${NB_FUZZ_HARNESSES:-"vdb mesh depth envmap"}
IGNORE_CRASHES=${NB_FUZZ_IGNORE_CRASHES:-1}
NB=${NB_PREFIX:-/opt/nb}
OUT=${OUT:-/tmp/fuzzout}
W=${NB_WORK:-/tmp/nbfuzz}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
F=$REPO/.fuzz
cd "$REPO"
mkdir -p "$OUT/artifacts"
exec > >(tee -a "$OUT/run.log") 2>&1
left() { echo $((DEADLINE - $(date +%s))); }
t() { echo "t=$(( $(date +%s) - T0 ))s"; }

echo "=== scripts/fuzz-bundle/run.sh: $(date -u) OPENIMAGEIO_OPTIONS=${OPENIMAGEIO_OPTIONS:-try_all_readers=0} repo $REPO OUT $OUT budget ${BUDGET}s harnesses: $HARNESSES forks $FORKS"
uname -a; grep PRETTY_NAME /etc/os-release 2>/dev/null; ldd --version 2>/dev/null | head -1
echo "$(nproc) CPUs; mmap_rnd_bits $(cat /proc/sys/vm/mmap_rnd_bits 2>/dev/null || echo ?); /dev/shm $(df -h /dev/shm 2>/dev/null | awk 'NR==2{print $4" free"}')"
free -g 2>/dev/null | head -2

# --- the bundle ---------------------------------------------------------------------------------
rm -rf "$W"; mkdir -p "$W/bin" "$NB"
untar() {  # untar FILE DIR (xz; Python's tarfile where there is no xz binary)
    if command -v xz >/dev/null; then timeout -k 5 90 tar -xJf "$1" -C "$2"
    else timeout -k 5 90 python3 -c "import tarfile,sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$1" "$2"; fi
}
untar "$F/libs.tar.xz" "$NB" || { echo "FATAL: cannot unpack libs.tar.xz"; exit 1; }
[ -f "$F/extra-libs.tar.xz" ] && { untar "$F/extra-libs.tar.xz" "$NB" || { echo "FATAL: extra-libs.tar.xz"; exit 1; }; }
untar "$F/bin.tar.xz" "$W/bin" || { echo "FATAL: cannot unpack bin.tar.xz"; exit 1; }
export LD_LIBRARY_PATH=$NB/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
# OpenImageIO (depth, envmap) tries every reader when the extension's one rejects a file; the bundle's
# DICOM, HEIF, RAW, ffmpeg and OpenCV libraries are code-less stand-ins (.gpu's), which crash there
# (a SEGV in DICOMInput::seek_subimage on the empty input). So no fallback readers on the device.
export OPENIMAGEIO_OPTIONS=${OPENIMAGEIO_OPTIONS:-try_all_readers=0}
echo "$(ls "$NB/lib" | wc -l) libraries in $NB/lib; harnesses: $(ls "$W/bin" | tr '\n' ' ') ($(t))"
# The harnesses were compiled in $SRC (data files are found there at run time): link it here.
SRC=$(cat "$F/SOURCE_DIR" 2>/dev/null)
if [ -n "$SRC" ] && [ ! -e "$SRC" ]; then
    mkdir -p "$(dirname "$SRC")" && ln -s "$REPO" "$SRC" && echo "linked $SRC -> $REPO"
fi
for h in $HARNESSES; do
    m=$(LD_LIBRARY_PATH=$LD_LIBRARY_PATH ldd "$W/bin/fuzz_$h" 2>&1 | grep -c 'not found')
    [ "$m" = 0 ] || { echo "fuzz_$h: $m libraries not found:"; ldd "$W/bin/fuzz_$h" | grep 'not found'; }
done

# --- preflight: each harness runs 2 inputs. Clang 14's ASan can die at start ("AddressSanitizer:
# DEADLYSIGNAL" forever) where the kernel randomises mmap with more than 28 bits; then run
# everything with ASLR off (setarch -R, else Python's personality call), never touching sysctls.
WRAP=()
preflight() {
    local ok=1 h rc
    for h in $HARNESSES; do
        timeout -k 2 30 "${WRAP[@]}" "$W/bin/fuzz_$h" -runs=2 -artifact_prefix="$W/pre-$h-" >"$W/pre-$h.log" 2>&1 || { rc=$?; ok=0; echo "preflight ${WRAP[*]} fuzz_$h: rc $rc"; tail -c 600 "$W/pre-$h.log"; echo; }
    done
    [ $ok = 1 ]
}
if ! preflight; then
    if setarch "$(uname -m)" -R true 2>/dev/null; then WRAP=(setarch "$(uname -m)" -R)
    else WRAP=(python3 -c 'import ctypes,os,sys; ctypes.CDLL(None).personality(0x0040000); os.execv(sys.argv[1], sys.argv[1:])'); fi
    echo "retrying with ASLR off: ${WRAP[*]}"
    preflight || echo "WARNING: preflight still fails; fuzzing anyway"
fi
echo "preflight done ($(t)) wrap: ${WRAP[*]:-none}"

# --- fuzz: all harnesses at once ----------------------------------------------------------------
MARGIN=45   # the last jobs finish their input (<= -timeout 25 s), then summary and tarballs
L=$(( $(left) - MARGIN ))
[ "$SECS" -gt "$L" ] && SECS=$L
echo "=== fuzzing $SECS s each ($(t), $(left) s of the budget left)"
declare -A PID
for h in $HARNESSES; do
    n=$(eval echo "\${NB_FORKS_$h:-$FORKS}")
    mkdir -p "$W/$h/corpus" "$W/$h/tmp" "$W/$h/seen"
    dirs=("$W/$h/corpus" "tests/fuzz/corpus/$h")
    [ -d "tests/fuzz/regressions/$h" ] && dirs+=("tests/fuzz/regressions/$h")
    echo "$n" >"$W/$h/forks"
    # TMPDIR: the fork parent's work folder (children's logs, read by the watcher below).
    TMPDIR=$W/$h/tmp timeout -k 10 $((SECS + 35)) "${WRAP[@]}" "$W/bin/fuzz_$h" -fork="$n" \
        -ignore_crashes="$IGNORE_CRASHES" -timeout=25 -rss_limit_mb=2048 -print_final_stats=1 \
        -max_total_time="$SECS" -artifact_prefix="$OUT/artifacts/$h-" "${dirs[@]}" >"$OUT/$h.log" 2>&1 &
    PID[$h]=$!
    echo "fuzz_$h: pid ${PID[$h]}, -fork=$n"
done

# Watcher, once a second while any parent runs: the executions of each child job as last seen in
# its log (the parent counts a job only when it merges it, so jobs still running at the end are
# missing from its "#N"), and the peak RSS (VmHWM) of every fuzz_<h> process.
running() { local h; for h in $HARNESSES; do kill -0 "${PID[$h]}" 2>/dev/null && return 0; done; return 1; }
declare -A RSS
STOP_AT=$(( $(date +%s) + SECS ))
for h in $HARNESSES; do RSS[$h]=0; done
while running; do
    for h in $HARNESSES; do
        for lg in "$W/$h"/tmp/libFuzzerTemp.FuzzWithFork*.dir/[0-9]*.log; do
            [ -f "$lg" ] || continue
            j=$(basename "$lg" .log)
            n=$(grep -aoE '^(#[0-9]+|stat::number_of_executed_units: *[0-9]+)' "$lg" 2>/dev/null | tail -1 | grep -oE '[0-9]+$')
            [ -n "$n" ] && [ "$n" -gt "$(cat "$W/$h/seen/$j" 2>/dev/null || echo 0)" ] && echo "$n" >"$W/$h/seen/$j"
            # A child's whole report (stack as module+offset: symbolize with the unstripped build), the
            # first 20 per harness, when caught before the parent deletes the log.
            if [ ! -f "$OUT/artifacts/$h-joblog-$j.txt" ] && [ "$(ls "$OUT/artifacts" | grep -c "^$h-joblog-")" -lt 20 ] &&
               grep -aqE 'ERROR: (AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|libFuzzer)|runtime error:|FINDING' "$lg" 2>/dev/null; then
                tail -c 200000 "$lg" >"$OUT/artifacts/$h-joblog-$j.txt" 2>/dev/null
            fi
        done
    done
    for p in /proc/[0-9]*; do
        c=$(cat "$p/comm" 2>/dev/null) || continue
        case "$c" in fuzz_*) h=${c#fuzz_}
            [ -n "${RSS[$h]+x}" ] || continue
            r=$(awk '/^VmHWM/{print int($2/1024)}' "$p/status" 2>/dev/null)
            [ -n "$r" ] && [ "$r" -gt "${RSS[$h]}" ] && RSS[$h]=$r ;;
        esac
    done
    # At the time limit, the STOP file the fork parent itself writes when it stops (it checks the time
    # only when a job ends, and a job lasts up to min(300, job number) s): the children end within a
    # second (or after their current input), so the parent stops at about $SECS s.
    if [ "$(date +%s)" -ge "$STOP_AT" ]; then
        for h in $HARNESSES; do for d in "$W/$h"/tmp/libFuzzerTemp.FuzzWithFork*.dir; do
            [ -d "$d" ] && [ ! -s "$d/STOP" ] && printf x >"$d/STOP"; done; done
    fi
    [ "$(left)" -lt 12 ] && { echo "deadline: stopping the harnesses"; for h in $HARNESSES; do kill -INT "${PID[$h]}" 2>/dev/null; done; sleep 3; break; }
    sleep 1
done
declare -A RC
for h in $HARNESSES; do wait "${PID[$h]}"; RC[$h]=$?; done
echo "=== fuzzing done ($(t))"

# --- summary ------------------------------------------------------------------------------------
{
echo "nimbus fuzz run $(date -u +%F\ %T) UTC on $(uname -n): $(nproc) CPUs, ${SECS} s per harness, all at once; wrap: ${WRAP[*]:-none}; ignore_crashes=$IGNORE_CRASHES"
echo "executions = merged (the parent's last #N: the jobs it merged) + in-flight (jobs still running at the stop, as last seen in their logs: a floor)"
printf '%-7s %-5s %-4s %-10s %-9s %-10s %-8s %-7s %-7s %-7s %-16s %-8s %-14s %s\n' harness exit forks executions merged in-flight exec/s /core cov ft corpus new-units peakRSS_MB findings
for h in $HARNESSES; do
    lg=$OUT/$h.log
    last=$(grep -aE '^#[0-9]+: cov:' "$lg" | tail -1)
    merged=$(sed -n 's/^#\([0-9]*\):.*/\1/p' <<<"$last"); merged=${merged:-0}
    cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
    ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
    corp=$(sed -n 's/.* corp: \([0-9]*\).*/\1/p' <<<"$last")
    el=$(sed -n 's/^INFO: exiting: .* time: \([0-9]*\)s.*/\1/p' "$lg" | tail -1)
    [ -n "$el" ] || el=$(sed -n 's/.* time: \([0-9]*\)s.*/\1/p' <<<"$last")
    jobs=" $(grep -aoE 'job: [0-9]+' "$lg" | awk '{print $2}' | tr '\n' ' ') "
    inflight=0
    for s in "$W/$h"/seen/*; do
        [ -f "$s" ] || continue
        j=$(basename "$s")
        [[ "$jobs" == *" $j "* ]] || inflight=$((inflight + $(cat "$s")))
    done
    total=$((merged + inflight))
    n=$(cat "$W/$h/forks")
    rate=$([ "${el:-0}" -gt 0 ] && echo $((total / el)) || echo '?')
    pc=$([ "${el:-0}" -gt 0 ] && echo $((total / el / n)) || echo '?')
    newu=$(ls "$W/$h/corpus" | wc -l); newkb=$(du -sk "$W/$h/corpus" | cut -f1)
    found=$(find "$OUT/artifacts" -name "$h-*" ! -name "$h-joblog-*" 2>/dev/null | wc -l)
    kinds=$(find "$OUT/artifacts" -name "$h-*" ! -name "$h-joblog-*" 2>/dev/null | sed "s|.*/$h-||; s/-.*//" | sort | uniq -c | awk '{printf "%s %s, ", $1, $2}')
    otc=$(sed -n 's/.* oom\/timeout\/crash: \([0-9/]*\).*/\1/p' <<<"$last")
    printf '%-7s %-5s %-4s %-10s %-9s %-10s %-8s %-7s %-7s %-7s %-16s %-8s %-14s %s\n' "$h" "${RC[$h]}" "$n" "$total" "$merged" "$inflight" \
        "$rate" "$pc" "${cov:-?}" "${ft:-?}" "${corp:-?} (${el:-?}s)" "$newu/${newkb}KB" "${RSS[$h]}" "$found ${kinds:+(${kinds%, })} oom/timeout/crash jobs ${otc:-?}"
done
echo
for h in $HARNESSES; do
    echo "--- $h: $(grep -aE '^INFO: (fuzzed for|exiting|-fork=.*seed inputs)' "$OUT/$h.log" | tr '\n' ';')"
    grep -aE 'ERROR:|runtime error:|FINDING' "$OUT/$h.log" | sort | uniq -c | sort -rn | head -15
done
} >"$OUT/summary.txt" 2>&1
cat "$OUT/summary.txt"

# --- the files: findings and new corpus units (tarballs: $OUT brings back 8 files) ----------------
if [ -n "$(ls -A "$OUT/artifacts")" ]; then
    tar -C "$OUT" -czf "$OUT/artifacts.tar.gz" artifacts && rm -rf "$OUT/artifacts"
    echo "artifacts.tar.gz: $(tar -tzf "$OUT/artifacts.tar.gz" | grep -vc '/$') files, $(du -h "$OUT/artifacts.tar.gz" | cut -f1)"
else
    rmdir "$OUT/artifacts"; echo "no artifacts"
fi
cs=(); for h in $HARNESSES; do cs+=("$h/corpus"); done
timeout -k 2 $(( $(left) > 8 ? $(left) - 3 : 5 )) tar -C "$W" -czf "$OUT/corpora.tar.gz" "${cs[@]}"
s=$(stat -c %s "$OUT/corpora.tar.gz" 2>/dev/null || echo 0)
[ "$s" -gt 16000000 ] && { echo "corpora.tar.gz $s bytes: over the 16 MiB a file, dropped"; rm -f "$OUT/corpora.tar.gz"; }
for h in $HARNESSES; do
    sz=$(stat -c %s "$OUT/$h.log"); [ "$sz" -gt 2000000 ] && { tail -c 2000000 "$OUT/$h.log" >"$W/l" && cat "$W/l" >"$OUT/$h.log"; }
done
echo "=== done ($(t)); OUT: $(ls "$OUT" | tr '\n' ' ')"
# let tee write the last lines before the command returns
exec >/dev/null 2>&1; sleep 1
