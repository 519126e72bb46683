#!/usr/bin/env python3
# mkstub.py LIB OUTDIR: a stand-in for LIB with the same soname, version definitions and dynamic
# symbols (functions return a pointer to zeroed memory, data and TLS objects are zero-filled at
# their real sizes) and no dependencies: loads where LIB would, so that a library that needs LIB
# but is never asked to call into it (OIIO's movie, DICOM, OpenCV, HEIF and camera-raw readers;
# LLVM's Z3 and libxml2) loads without LIB's tree of dependencies. Used by make_bundle.sh to keep
# the GPU bundle (issue 13: the path tracer "on any OpenCL GPU where present", timed by run.sh on a
# borrowed GPU machine) within what the device tool carries.
import os, re, subprocess, sys, tempfile
lib, outdir = sys.argv[1], sys.argv[2]
dyn = subprocess.run(['readelf', '-dW', lib], capture_output=True, text=True, check=True).stdout
soname = re.search(r'\(SONAME\).*\[(.*)\]', dyn).group(1)
ver = subprocess.run(['readelf', '-VW', lib], capture_output=True, text=True, check=True).stdout
vdefs, base = [], None
sec = ver.split("Version definition section")[1].split("Version needs section")[0] if "Version definition section" in ver else ""
for m in re.finditer(r'Flags: (\S+)\s+Index: \d+\s+Cnt: \d+\s+Name: (\S+)', sec):
    if m.group(1) == 'BASE': base = m.group(2)
    else: vdefs.append(m.group(2))
syms = subprocess.run(['readelf', '--dyn-syms', '-W', lib], capture_output=True, text=True, check=True).stdout
asm = ['\t.text', '\t.p2align 4', 'nb_stub_ret:', '\tleaq nb_stub_zero(%rip), %rax', '\tret',
       '\t.local nb_stub_zero', '\t.comm nb_stub_zero, 65536, 64']
nodes = {v: [] for v in vdefs}
n = 0
seen = set()
for line in syms.splitlines():
    f = line.split()
    if len(f) < 8 or not f[0].endswith(':') or f[0] == 'Num:': continue
    size, typ, bind, ndx, name = f[2], f[3], f[4], f[6], f[7]
    if ndx in ('UND', 'ABS') or bind == 'LOCAL' or typ in ('SECTION', 'FILE'): continue
    # Weak and unique symbols are template instantiations, inline functions and their vtables,
    # typeinfo and statics (std::map<...>::operator[], openvdb:: templates): every user holds its
    # own copy, and a stand-in's would interpose on the real ones of the libraries loaded after it
    # (OpenColorIO crashed in a std::map insert answered by the AX stand-in). Likewise the C++
    # runtime's own namespaces.
    if bind in ('WEAK', 'UNIQUE') or re.match(r'_Z(N|NK|TI|TV|TS|TT|Th|Tv)?(St|S[a-z]|9__gnu_cxx)', name): continue
    if name in seen: continue
    seen.add(name)
    size = int(size, 16) if size.startswith('0x') else int(size)
    m = re.match(r'^([^@]+)(@@?)(.+)$', name)
    sym, at, v = (m.group(1), m.group(2), m.group(3)) if m else (name, '', None)
    if v == base: v = None
    n += 1
    label = sym if (at != '@') else 'nb_stub_alias_%d' % n
    if typ in ('FUNC', 'IFUNC', 'NOTYPE'):
        asm += ['\t.text', '\t.globl %s' % label, '\t.type %s, @function' % label, '%s:' % label,
                '\tjmp nb_stub_ret', '\t.size %s, .-%s' % (label, label)]
    elif typ == 'TLS':
        asm += ['\t.section .tbss,"awT",@nobits', '\t.p2align 4', '\t.globl %s' % label,
                '\t.type %s, @object' % label, '\t.size %s, %d' % (label, max(size, 1)), '%s:' % label,
                '\t.zero %d' % max(size, 1)]
    else:  # OBJECT, COMMON, gnu_unique
        asm += ['\t.data', '\t.p2align 4', '\t.globl %s' % label, '\t.type %s, @object' % label,
                '\t.size %s, %d' % (label, max(size, 1)), '%s:' % label, '\t.zero %d' % max(size, 1)]
    if at == '@':
        asm.append('\t.symver %s, %s@%s' % (label, sym, v))
    elif v:
        nodes.setdefault(v, []).append(sym)
with tempfile.TemporaryDirectory() as t:
    s = os.path.join(t, 'stub.S'); open(s, 'w').write('\n'.join(asm) + '\n\t.section .note.GNU-stack,"",@progbits\n')
    cmd = ['gcc', '-shared', '-nostdlib', '-Wl,-soname,' + soname, '-Wl,--hash-style=both', '-o', os.path.join(outdir, soname), s]
    if vdefs:
        mp = os.path.join(t, 'v.map')
        open(mp, 'w').write(''.join('%s {%s};\n' % (v, (' global: ' + ' '.join(x + ';' for x in nodes[v]) + ' ') if nodes[v] else ' ') for v in vdefs))
        cmd.insert(1, '-Wl,--version-script=' + mp)
    subprocess.run(cmd, check=True)
print('%s: %d symbols, %d versions' % (soname, n, len(vdefs)))
