#!/usr/bin/env python3
"""Functions over N lines (default 150) outside tests in src/ and crates/*/src/: python3 scripts/long_functions.py [N]."""
import os, re, sys
N = int(sys.argv[1]) if len(sys.argv) > 1 else 150
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
out = []
for base in ['src'] + [f'crates/{c}/src' for c in os.listdir(f'{root}/crates')]:
    for dp, dn, fn in os.walk(f'{root}/{base}'):
        for f in fn:
            if not f.endswith('.rs') or f == 'tests.rs':
                continue
            p = os.path.join(dp, f)
            lines = open(p).read().split('\n')
            in_test = False
            i = 0
            while i < len(lines):
                l = lines[i]
                if re.match(r'\s*#\[cfg\(test\)\]', l):
                    break  # rest of file is tests by convention
                m = re.match(r'\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+(\w+)', l)
                if m:
                    # find opening brace
                    j = i; depth = 0; started = False
                    while j < len(lines):
                        s = re.sub(r'//.*', '', lines[j])
                        s = re.sub(r'"(\\.|[^"\\])*"', '""', s)
                        s = re.sub(r"'(\\.|[^'\\])'", "''", s)
                        for ch in s:
                            if ch == '{': depth += 1; started = True
                            elif ch == '}': depth -= 1
                        if started and depth == 0: break
                        if not started and s.rstrip().endswith(';'): break
                        j += 1
                    n = j - i + 1
                    if started and n > N:
                        out.append((n, os.path.relpath(p, root), i + 1, m.group(6)))
                    i = j + 1 if started else i + 1
                    continue
                i += 1
for n, p, l, name in sorted(out, reverse=True):
    print(f'{n:4d} {p}:{l} {name}')
print(len(out), 'functions over', N)
