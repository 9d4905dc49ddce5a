#!/usr/bin/env python3
"""Module dependency cycles (run from the workspace root; CI runs it) of each crate: a module A depends on B when A's code (not its
comments) names crate::B. Prints the strongly connected components with more than one module."""
import re, os, glob, collections, sys
def graph(root, mods):
    g = collections.defaultdict(set)
    for p in glob.glob(root + '/**/*.rs', recursive=True):
        top = os.path.relpath(p, root).split('/')[0].replace('.rs', '')
        if top in ('lib', 'main', 'bin'):
            continue
        code = '\n'.join(l for l in open(p).read().split('\n') if not l.strip().startswith('//'))
        for m in re.findall(r'crate::([a-z_]+)', code):
            if m != top and m in mods:
                g[top].add(m)
    return g
def sccs(g):
    index, low, st, on, res, i = {}, {}, [], set(), [], [0]
    def sc(v):
        index[v] = low[v] = i[0]; i[0] += 1; st.append(v); on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                sc(w); low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            c = []
            while True:
                w = st.pop(); on.discard(w); c.append(w)
                if w == v: break
            if len(c) > 1: res.append(c)
    for v in list(g):
        if v not in index: sc(v)
    return res
roots = sys.argv[1:] or ['src', 'crates/linalg/src', 'crates/cli/src', 'crates/fixtures/src', 'validation/src', 'python/src']
found = False
for root in roots:
    mods = {os.path.basename(p).replace('.rs', '') for p in glob.glob(root + '/*')}
    g = graph(root, mods)
    cycles = sccs(g)
    print(root, 'cycles:', cycles if cycles else 'none')
    found = found or bool(cycles)
    for c in cycles:
        for a in c:
            print('   ', a, '->', sorted(x for x in g[a] if x in c))
sys.exit(1 if found else 0)
