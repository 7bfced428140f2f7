#!/usr/bin/env python3
"""Import circles between the modules of each crate: prints every circle, exits 1 if any.

Usage: scripts/module-circles.py [SRC_DIR...]   (default: every crate's src/)

An edge is a `use crate::`/`super::`/`self::` path (or such a path in code) from one module to
another, test modules left out; a module and its own submodules or ancestors are not a circle.
docs/ARCHITECTURE.md: "no import circles between the modules of a crate".
"""
import os, re, sys

def modules(src):
    mods = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith('.rs'): continue
            p = os.path.join(root, f)
            rel = os.path.relpath(p, src)[:-3].split(os.sep)
            if rel[-1] in ('mod',): rel = rel[:-1]
            if rel in (['lib'], ['main']): rel = []
            mods[tuple(rel)] = p
    return mods

def strip_tests(text):
    m = re.search(r'#\[cfg\(test\)\]\s*(pub(\(crate\))?\s+)?mod \w+\s*\{', text)
    text = text[:m.start()] if m else text
    text = re.sub(r'//[^\n]*', '', text)
    return text

def expand(group):
    # expand a use tree like a::{b, c::{d}} into paths
    out = []
    def rec(prefix, s):
        s = s.strip()
        i = s.find('{')
        if i < 0:
            for part in s.split(','):
                part = part.strip()
                if part: out.append(prefix + part.split(' as ')[0].strip())
            return
        head = s[:i]
        # split the braces content at top level
        depth = 0; start = i + 1; items = []; items_s = s[i+1:]
        for j in range(i, len(s)):
            if s[j] == '{': depth += 1
            elif s[j] == '}':
                depth -= 1
                if depth == 0:
                    items_s = s[i+1:j]; break
        parts = []; depth = 0; cur = ''
        for ch in items_s:
            if ch == ',' and depth == 0: parts.append(cur); cur = ''; continue
            if ch == '{': depth += 1
            if ch == '}': depth -= 1
            cur += ch
        parts.append(cur)
        for p in parts:
            if p.strip(): rec(prefix + head, p)
    rec('', group)
    return out

def edges(src):
    mods = modules(src)
    E = {}
    for mod, path in mods.items():
        text = strip_tests(open(path).read())
        paths = []
        for m in re.finditer(r'\buse\s+([^;]+);', text):
            paths += expand(m.group(1).replace('\n', ' '))
        for m in re.finditer(r'\b(crate|super|self)::[A-Za-z_][A-Za-z0-9_:]*', text):
            paths.append(m.group(0))
        for p in paths:
            segs = [x for x in p.replace(' ', '').split('::') if x]
            if not segs: continue
            if segs[0] == 'crate': base = []; segs = segs[1:]
            elif segs[0] in ('super', 'self'):
                # a file module foo/bar.rs: self = (foo, bar), super = (foo)
                base = list(mod)
                while segs and segs[0] in ('super', 'self'):
                    if segs[0] == 'super': base = base[:-1]
                    segs = segs[1:]
            else: continue
            full = base + segs
            # longest module prefix
            target = None
            for k in range(len(full), 0, -1):
                if tuple(full[:k]) in mods: target = tuple(full[:k]); break
            if target is None or target == mod: continue
            # a module's own submodules and its ancestors are not circles of interest
            if target[:len(mod)] == mod or mod[:len(target)] == target: continue
            E.setdefault(mod, set()).add(target)
    return mods, E

def sccs(nodes, E):
    idx = {}; low = {}; st = []; on = set(); out = []; c = [0]
    sys.setrecursionlimit(10000)
    def s(v):
        idx[v] = low[v] = c[0]; c[0] += 1; st.append(v); on.add(v)
        for w in E.get(v, ()):
            if w not in idx: s(w); low[v] = min(low[v], low[w])
            elif w in on: low[v] = min(low[v], idx[w])
        if low[v] == idx[v]:
            comp = []
            while True:
                w = st.pop(); on.discard(w); comp.append(w)
                if w == v: break
            out.append(comp)
    for v in nodes:
        if v not in idx: s(v)
    return [c for c in out if len(c) > 1]

def main():
    import glob
    srcs = sys.argv[1:] or sorted(glob.glob('crates/*/*/src')) + ['crates/cli/src']
    found = 0
    for src in srcs:
        mods, E = edges(src)
        name = lambda m: '::'.join(m) or 'lib'
        for comp in sccs(sorted(mods), E):
            comp = sorted(comp)
            pairs = [f"{name(a)}->{name(b)}" for a in comp for b in sorted(E.get(a, ())) if b in comp]
            print(f"{src}: circle {{{', '.join(map(name, comp))}}}: {'; '.join(pairs)}")
            found += 1
    if found:
        print(f"{found} import circle(s): move what both modules need to one side or to a third module")
    return 1 if found else 0

if __name__ == '__main__':
    sys.exit(main())
