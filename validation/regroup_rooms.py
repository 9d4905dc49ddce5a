#!/usr/bin/env python3
"""Regroup the core's flat modules (src/*.rs, src/*/) into a few rooms (issue 34, item 6).

Run from the workspace root, on any later state of main: `python3 validation/regroup_rooms.py`
(`--no-fmt` skips the final `cargo fmt`; `--dry-run` prints the moves and changes nothing).
It is idempotent: a second run finds everything in place and changes nothing. It
1. `git mv`s each module's file (`x.rs`) and folder (`x/`) into its room (`src/<room>/`);
2. writes each new room's `mod.rs` (a module doc saying what it holds, then `pub mod` lines),
   or, for a room that is already a module (`analysis`), adds the `pub mod` lines and a
   paragraph to its doc;
3. rewrites every path that named a moved module, in every tracked or new text file of the
   workspace (src/, tests/, benches/, examples/, crates/*, python/, fuzz/, validation/, *.md):
   `crate::x` (core only: src/), `tetfem::x`, the first level of `use crate::{x, ..}` and
   `use tetfem::{x, ..}` lists, `super::…::x` paths that reach the crate root from the core's
   files, `pub(super)` in a file that moves one level down (it meant the crate), the crate
   root's own `pub mod`/`pub use x::` lines and bare `[`x`]` doc links, file paths `src/x.rs`
   and `src/x/` in comments and docs, and validation/module_cycles.py's `LAYERS` for `src`;
4. runs `cargo fmt --all` (use lists are re-sorted: `crate::{assembly, error}` became
   `crate::{fe::assembly, base::error}`) and the same for fuzz/.

The rooms, in layer order (a room may use its own and earlier rooms only; module_cycles.py
checks it). Module names inside a room stay: `tetfem::bc::constraints`, `tetfem::fe::element`.
- base     error, warning, atomic_file, input_file, memory — what every room uses and which
           knows no mechanics: the one error type, the warning type, whole-file writes, input
           file reading, memory estimates.
- mesh     (already a room) the geometry and topology of tets, generators, selections, mesh
           file I/O — knows no material or element.
- fe       material, materials, element, quadrature, quality, assembly — the finite element
           discretisation: what a tet is made of (material, per tet), the element seam and its
           quadrature, the per-tet quality (it asks the element seam, so it cannot be in mesh),
           and the global assembly on a pattern built once.
- bc       constraints, loads, amplitude, boundary_motion — what the user prescribes on the
           body: Dirichlet data and the DOF map, loads, time functions, prescribed motions.
- model    (already a room) force models: laws per point, forces and tangents per tet, the
           global assembly of a nonlinear force.
- contact  (already a room) rigid obstacles, the barrier, friction (uses bc's amplitudes).
- analysis (already a module: the problem definition and its combination rule) + problem,
           statics, nonlinear, dynamics, modal — every solve of a problem: the set-up made
           once, static (linear and Newton), time integration, modes.
- post     estimate, adequacy, convergence, error_norms, output — what is made of a solution:
           error estimates and norms, model adequacy, convergence rates, the writers.
- prelude  stays at the root (the common path in one import), as do the root re-exports
           (`tetfem::TetMesh`, `Material`, `StaticSolver`, ...): their `pub use` lines are
           rewritten, not removed. No alias is left at an old path (no Python, PETSc or serde
           name depends on a Rust module path: the Python module is `_tetfem`, serde names
           are the types' own).
"""
import os
import re
import subprocess
import sys

ROOMS = {
    'base': 'error warning atomic_file input_file memory',
    'fe': 'material materials element quadrature quality assembly',
    'bc': 'constraints loads amplitude boundary_motion',
    'analysis': 'problem statics nonlinear dynamics modal',
    'post': 'estimate adequacy convergence error_norms output',
}
# Each room's module doc (the first lines of its mod.rs); `analysis` has its own and gets
# ANALYSIS_DOC appended.
ROOM_DOCS = {
    'base': """//! The base room: what every other room uses and which knows no mechanics — the one error
//! type ([`error`]: each variant names its culprit), the warning type ([`warning`]: valid but
//! suspect input), whole-file atomic writes ([`atomic_file`]), input file reading
//! ([`input_file`]: sizes and line numbers) and peak-memory estimates made before allocating
//! ([`memory`]).""",
    'fe': """//! The finite element room: what a tet is made of and how it becomes matrices — the material
//! (E, ν, ρ: [`material`]) and a material per tet ([`materials`]), the element seam and its
//! 4- and 10-node tets ([`element`]), quadrature rules ([`quadrature`]), per-tet quality and
//! the mesh's warnings ([`quality`]: it asks the element seam, so it is here and not in
//! `mesh`), and the global stiffness and masses refilled on a pattern built once
//! ([`assembly`]).""",
    'bc': """//! The boundary-condition room: what the user prescribes on the body — Dirichlet data and the
//! free-DOF map ([`constraints`]), gravity, body, nodal and surface loads ([`loads`]), time
//! functions a(t) with ȧ, ä ([`amplitude`]) and prescribed motions of node sets
//! ([`boundary_motion`]).""",
    'post': """//! The post-processing room: what is made of a solution — the ZZ a-posteriori error estimate
//! ([`estimate`]), model adequacy advice ([`adequacy`]), convergence rates ([`convergence`]),
//! error norms against a reference ([`error_norms`]) and the writers of `.vtu`, `.pvd` and CSV
//! files ([`output`]).""",
}
ANALYSIS_DOC = """//!
//! The analysis room also holds every solve of a problem: the set-up made once ([`problem`]),
//! one linear solve ([`statics`]), Newton with load steps ([`nonlinear`]), time integration
//! ([`dynamics`]) and modes ([`modal`])."""
LIB_FLOW = """//! The modules live in rooms, in layer order (a room uses only itself and the rooms before it):
//! [`base`] → [`mesh`] → [`fe`] → [`bc`] → [`model`], [`contact`] → [`analysis`] → [`post`].
//! Data flows one way: mesh → material → element → assembly → analysis (its linear solves
//! through [`linalg`]) → outputs.
//!
"""
ROOM_ORDER = 'base mesh fe bc model contact analysis post'.split()
LAYERS_SRC = [
    'base',
    'mesh',
    'fe',
    'bc',
    'model contact',
    'analysis',
    'post',
    'prelude',
]
ROOM_OF = {m: room for room, mods in ROOMS.items() for m in mods.split()}
MOVED = sorted(ROOM_OF, key=len, reverse=True)
ALT = '|'.join(MOVED)
TEXT_EXT = ('.rs', '.md', '.py', '.pyi', '.toml', '.txt', '.sh', '.yml', '.yaml')
SKIP_DIRS = ('target/', 'fuzz/corpus/', 'fuzz/regressions/', 'assets/', '.git/')


def run(cmd, check=True):
    return subprocess.run(cmd, check=check, capture_output=True, text=True)


def move_modules(dry):
    """git mv src/x.rs and src/x/ into src/<room>/; returns the destinations."""
    moves = []
    for m, room in sorted(ROOM_OF.items()):
        for src, dst in ((f'src/{m}.rs', f'src/{room}/{m}.rs'), (f'src/{m}', f'src/{room}/{m}')):
            if not os.path.exists(src):
                continue
            if os.path.exists(dst):
                sys.exit(f'regroup_rooms: both {src} and {dst} exist; merge them by hand first')
            moves.append(dst)
            print(f'move {src} -> {dst}')
            if dry:
                continue
            os.makedirs(f'src/{room}', exist_ok=True)
            if run(['git', 'mv', src, dst], check=False).returncode != 0:
                os.rename(src, dst)  # a file not yet tracked (a helper's new file)
    return moves


def module_path(path):
    """src/a/b.rs -> ['a', 'b']; src/a/mod.rs -> ['a']; src/lib.rs -> []."""
    parts = os.path.relpath(path, 'src')[:-3].split('/')
    if parts[-1] in ('mod', 'lib'):
        parts = parts[:-1]
    return parts


def old_module_path(path, moved_now):
    """The module path a core file had before this run's moves (its room taken off), and
    whether it moved."""
    parts = module_path(path)
    if any(path == d or path.startswith(d + '/') for d in moved_now):
        return parts[1:], True
    return parts, False


def new_path(name):
    return f'{ROOM_OF[name]}::{name}' if name in ROOM_OF else name


def top_modules():
    """The crate root's module names after the move (rooms and modules left at the root)."""
    names = set(ROOM_OF)
    for p in os.listdir('src'):
        names.add(p[:-3] if p.endswith('.rs') else p)
    return names


def rewrite_supers(text, path, roots, moved_now):
    """`super::…::x` that reached the crate root from a core file: rewritten as `crate::x`
    when the file moved (its depth grew by one) or x moved (the crate path is then fixed by
    rewrite_paths). A `pub(super)` of a file that moved one level down meant the crate."""
    old, moved = old_module_path(path, moved_now)
    depth = len(old)

    def sup(mt):
        k = mt.group(1).count('super::')
        name = mt.group(2)
        if k != depth or depth == 0 or not (moved or name in ROOM_OF) or name not in roots:
            return mt.group(0)
        return 'crate::' + name

    text = re.sub(r'\b((?:super::)+)([a-z_0-9]+)\b', sup, text)
    if moved and depth == 1:
        text = text.replace('pub(super)', 'pub(crate)')
    return text


def rewrite_paths(text, prefixes):
    """`crate::x` / `tetfem::x` with x moved -> `…::room::x`; then the first level of
    `crate::{…}` / `tetfem::{…}` lists."""
    for pre in prefixes:
        text = re.sub(rf'\b{pre}::({ALT})\b(?!\s*!)', lambda mt: f'{pre}::{new_path(mt.group(1))}', text)
        text = rewrite_lists(text, pre)
    return text


def rewrite_lists(text, pre):
    out, i = [], 0
    for mt in re.finditer(rf'\b{pre}::\{{', text):
        if mt.start() < i:
            continue
        j = mt.end()
        out.append(text[i:j])
        depth, item_start = 0, True
        while j < len(text):
            c = text[j]
            if text.startswith('//', j):
                e = text.find('\n', j)
                e = len(text) if e < 0 else e
                out.append(text[j:e])
                j = e
                continue
            if item_start and depth == 0:
                if c.isspace():
                    out.append(c)
                    j += 1
                    continue
                w = re.match(r'[a-z_0-9]+\b', text[j:])
                if w and w.group(0) in ROOM_OF:
                    out.append(ROOM_OF[w.group(0)] + '::')
                item_start = False
            if c == '{':
                depth += 1
            elif c == '}':
                if depth == 0:
                    out.append(c)
                    j += 1
                    break
                depth -= 1
            elif c == ',' and depth == 0:
                item_start = True
            out.append(c)
            j += 1
        i = j
    out.append(text[i:])
    return ''.join(out)


def rewrite_file_paths(text):
    """`src/x.rs`, `src/x/…` (the core's, not `crates/…/src/`) -> `src/room/x…`."""
    return re.sub(rf'(?<![\w/.\-])src/({ALT})(?=\.rs\b|/)', lambda mt: f'src/{new_path(mt.group(1)).replace("::", "/")}', text)


def rewrite_lib(text):
    """The crate root: `pub mod x;` of moved modules become the rooms' lines; `pub use x::`
    and bare [`x`] doc links get the room; the doc's "Data flow one way" line names the rooms."""
    text = re.sub(r'//! Data flow one way:(?:.*\n)*?//!\n', LIB_FLOW, text, count=1)
    lines = [l for l in text.split('\n') if not re.fullmatch(rf'pub mod ({ALT});', l)]
    have = {mt.group(1) for l in lines for mt in [re.fullmatch(r'pub mod (\w+);', l)] if mt}
    last = max(k for k, l in enumerate(lines) if re.fullmatch(r'pub mod \w+;', l))
    for room in reversed(ROOM_ORDER):
        if room not in have and (room in ROOMS):
            lines.insert(last + 1, f'pub mod {room};')
    text = '\n'.join(lines)
    text = re.sub(rf'^(\s*pub(?:\(crate\))? use )({ALT})::', lambda mt: mt.group(1) + new_path(mt.group(2)) + '::', text, flags=re.M)
    text = re.sub(rf'\[`({ALT})`\](?!\()', lambda mt: f'[`{mt.group(1)}`]({new_path(mt.group(1))})', text)
    return text


def write_rooms(dry):
    for room, mods in ROOMS.items():
        path = f'src/{room}/mod.rs'
        decls = [f'pub mod {m};' for m in sorted(mods.split()) if os.path.exists(f'src/{room}/{m}.rs') or os.path.exists(f'src/{room}/{m}')]
        if dry:
            continue
        if room in ROOM_DOCS:
            if not os.path.exists(path):
                with open(path, 'w') as f:
                    f.write(ROOM_DOCS[room] + '\n\n' + '\n'.join(decls) + '\n')
            run(['git', 'add', path], check=False)  # so that the lead's commit has it
            continue
        # A room that already is a module: add what is missing.
        text = open(path).read()
        lines = text.split('\n')
        missing = [d for d in decls if d not in lines]
        if missing:
            mods_at = [k for k, l in enumerate(lines) if re.fullmatch(r'(pub(\(\w+\))? )?mod \w+;', l)]
            at = mods_at[-1] + 1 if mods_at else next(k for k, l in enumerate(lines) if not l.startswith('//!'))
            lines[at:at] = missing
        if ANALYSIS_DOC.split('\n')[1] not in lines:
            doc_end = next(k for k, l in enumerate(lines) if not l.startswith('//!'))
            lines[doc_end:doc_end] = ANALYSIS_DOC.split('\n')
        new = '\n'.join(lines)
        if new != text:
            with open(path, 'w') as f:
                f.write(new)


def rewrite_layers(text):
    body = ''.join(f"        '{l}',\n" for l in LAYERS_SRC)
    return re.sub(r"(    'src': \[\n)(.*?)(    \],)", lambda mt: mt.group(1) + body + mt.group(3), text, count=1, flags=re.S)


def files():
    out = run(['git', 'ls-files', '-co', '--exclude-standard']).stdout.split('\n')
    return [p for p in out if p.endswith(TEXT_EXT) and os.path.isfile(p) and not p.startswith(SKIP_DIRS) and p != 'validation/regroup_rooms.py']


def main():
    dry = '--dry-run' in sys.argv
    if not os.path.exists('src/lib.rs') or not os.path.exists('crates'):
        sys.exit('regroup_rooms: run from the workspace root')
    if run(['git', 'status', '--porcelain', '--', 'src'], check=False).stdout.strip() and not dry:
        print('regroup_rooms: note: src/ has uncommitted changes; they move too')
    moves = move_modules(dry)
    if dry:
        return
    write_rooms(dry)
    roots = top_modules()
    changed = 0
    for p in files():
        try:
            text = open(p, encoding='utf-8').read()
        except UnicodeDecodeError:
            continue
        new = text
        if p.endswith('.rs') and p.startswith('src/'):
            new = rewrite_supers(new, p, roots, moves)
            new = rewrite_paths(new, ['crate', 'tetfem'])
            if p == 'src/lib.rs':
                new = rewrite_lib(new)
        elif p.endswith('.rs'):
            new = rewrite_paths(new, ['tetfem'])
        else:
            new = re.sub(rf'\btetfem::({ALT})\b', lambda mt: f'tetfem::{new_path(mt.group(1))}', new)
        new = rewrite_file_paths(new)
        if p == 'validation/module_cycles.py':
            new = rewrite_layers(new)
        if new != text:
            changed += 1
            with open(p, 'w', encoding='utf-8') as f:
                f.write(new)
    print(f'regroup_rooms: {len(moves)} move(s), {changed} file(s) rewritten')
    if '--no-fmt' not in sys.argv:
        run(['cargo', 'fmt', '--all'], check=False)
        if os.path.exists('fuzz/Cargo.toml'):
            run(['cargo', 'fmt', '--manifest-path', 'fuzz/Cargo.toml'], check=False)


if __name__ == '__main__':
    main()
