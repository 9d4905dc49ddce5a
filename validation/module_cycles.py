#!/usr/bin/env python3
"""Module dependency checks of each crate (run from the workspace root; CI runs it).

A top-level module A depends on B when A's code (not its comments) names `crate::B`, or reaches
B through `super::` (`super::B` from a top-level module's own file, `super::super::B` from a
file one level down, ...). Two checks:
1. no cycles: prints the strongly connected components with more than one module;
2. the layer order: where a crate documents one (LAYERS below, the core's from ARCHITECTURE.md),
   a module may use modules of its own or an earlier layer only; each edge to a later layer is
   printed.
Exit status 1 when either finds something."""
import re, os, glob, collections, sys

# The core's data flow (ARCHITECTURE.md, "Data flow in the core"): each line a layer, earliest
# first; a module may use its own layer and those above it.
LAYERS = {
    'src': [
        'base',
        'mesh',
        'fe',
        'bc',
        'model contact',
        'analysis',
        'post',
        'prelude',
    ],
}


def module_path(root, path):
    """The module path of a file: src/a/b.rs -> ['a', 'b']; src/a/mod.rs -> ['a']."""
    parts = os.path.relpath(path, root)[:-3].split('/')
    if parts[-1] == 'mod':
        parts = parts[:-1]
    return parts


def graph(root, mods):
    g = collections.defaultdict(set)
    for p in glob.glob(root + '/**/*.rs', recursive=True):
        here = module_path(root, p)
        top = here[0]
        if top in ('lib', 'main', 'bin'):
            continue
        code = '\n'.join(l for l in open(p).read().split('\n') if not l.strip().startswith('//'))
        for m in re.findall(r'crate::([a-z_0-9]+)', code):
            if m != top and m in mods:
                g[top].add(m)
        # super::…::name resolves against the file's module path (a mod.rs is its folder's
        # module; a plain file is a module inside its folder's).
        for supers, m in re.findall(r'\b((?:super::)+)([a-z_0-9]+)', code):
            depth = supers.count('super::')
            base = here[:len(here) - depth]
            if not base and m != top and m in mods:
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


def layer_violations(root, g, mods):
    layers = LAYERS.get(root)
    if not layers:
        return []
    rank = {m: k for k, line in enumerate(layers) for m in line.split()}
    unplaced = sorted(m for m in mods if m not in rank and m not in ('lib', 'main', 'bin'))
    out = [f'{m}: not in the documented layer order' for m in unplaced]
    for a in sorted(g):
        for b in sorted(g[a]):
            if a in rank and b in rank and rank[b] > rank[a]:
                out.append(f'{a} (layer {rank[a]}) uses {b} (layer {rank[b]})')
    return out


roots = sys.argv[1:] or ['src', 'crates/linalg/src', 'crates/scene/src', 'crates/cli/src', 'crates/fixtures/src', 'validation/src', 'python/src']
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
    bad = layer_violations(root, g, mods)
    if root in LAYERS:
        print(root, 'layer order:', 'kept' if not bad else f'{len(bad)} edge(s) against it')
    for line in bad:
        print('   ', line)
    found = found or bool(bad)
sys.exit(1 if found else 0)
