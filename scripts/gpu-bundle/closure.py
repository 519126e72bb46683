#!/usr/bin/env python3
# closure.py ROOT... [--stub SONAME ...]: DT_NEEDED closure (resolved against the system's ld cache),
# subtrees under stubbed sonames cut off; prints "soname path" per library ("STUB" for a stubbed one,
# "NOTFOUND" if unresolved), glibc, libstdc++ and libgcc_s left out. Used by make_bundle.sh, which
# packs the path tracer for a borrowed GPU machine (issue 13: the path tracer "on any OpenCL GPU
# where present", its kernels timed there by run.sh when a task is lent a GPU).
import subprocess, sys, os, re
EXCL = re.compile(r'^(libc|libm|libdl|librt|libpthread|ld-linux-x86-64|libresolv|libutil|libstdc\+\+|libgcc_s)\.so')
args = sys.argv[1:]
stubs = set()
if '--stub' in args:
    i = args.index('--stub'); stubs = set(args[i+1:]); args = args[:i]
cache = {}
for line in subprocess.run(['ldconfig', '-p'], capture_output=True, text=True).stdout.splitlines():
    m = re.match(r'\s+(\S+) \(libc6,x86-64[^)]*\) => (\S+)', line)
    if m and m.group(1) not in cache: cache[m.group(1)] = m.group(2)
def needed(path):
    out = subprocess.run(['readelf', '-dW', path], capture_output=True, text=True).stdout
    rp = re.findall(r'R(?:UN)?PATH.*\[(.*)\]', out)
    return re.findall(r'\(NEEDED\).*\[(.*)\]', out), rp
seen = {}
todo = list(args)
while todo:
    p = todo.pop()
    for n, in [(x,) for x in needed(p)[0]]:
        if n in seen or EXCL.match(n): continue
        if n in stubs: seen[n] = 'STUB'; continue
        r = cache.get(n)
        if not r: seen[n] = 'NOTFOUND'; continue
        seen[n] = r; todo.append(r)
for n, r in sorted(seen.items()): print(n, r)
