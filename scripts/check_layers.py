#!/usr/bin/env python3
"""Includes point one way (issue 38): a file may include files of its own layer and of lower layers only.

Usage: scripts/check_layers.py [REPO_ROOT] [--no-cycles] [--list-layers]

Reads every `#include "..."` (and `#include <...>`) in the folders of SCANNED, resolves a quoted include to a
file of the repository the way the compiler does (the including file's folder, then the include directories of
INCLUDE_DIRS in CMakeLists.txt's order), gives each file the layer of the longest folder of LAYERS that holds it,
and fails (exit status 1) listing

  file:line: #include "x" -- layer A (rank a) includes a higher layer, B (rank b): path

for every include of a higher layer, and of another layer of the same rank (peers never include each other:
the estimator and the reference stand side by side). It also fails on a third-party header that LIBRARIES keeps
away from a layer (core/ includes none of them, nor anything of sim/), on an ambiguous include (a test header
that shadows a header of sim/), and, unless --no-cycles, when units (a folder's foo.h, foo-inl.h and foo.cpp) of
sim/ include each other in a loop: the loop's units are listed with the includes that close it (those running
to a higher layer, else the fewest a greedy order finds).
Standard library only; run from CI as `python3 scripts/check_layers.py .`.
"""
import os
import re
import sys

# Folder (relative to the root, with a trailing slash) -> (layer name, rank). Lowest first. The longest folder
# that holds a file gives its layer. Equal ranks are peers: neither may include the other.
LAYERS = [
    ("core/", "core", 0),
    ("sim/util/", "util", 1),            # hash, text, clock, input files, JSON, isolation, atomic files, images
    ("sim/assets/", "assets", 2),        # Assimp, glTF checks, textures: the importer of third-party files
    ("sim/scene/", "scene", 3),          # sequence, animation, shapes, sky, Embree, G-buffer, shading point
    ("sim/estimator/", "estimator", 4),  # pipeline, passes, presets, settings, reservoir diagnostics
    ("sim/reference/", "reference", 4),  # converged reference, its samplers and cache (a peer of the estimator)
    ("sim/metrics/", "metrics", 5),      # metrics, FLIP, ensembles, compare, summary, metrics.csv
    ("sim/output/", "output", 6),        # EXR/PNG frames, background writer, manifest, report, plots
    ("sim/run/", "run", 7),              # the frame loop, `run`, memory estimate, progress
    ("sim/study/", "study", 8),          # sweeps
    ("sim/app/", "app", 9),              # the command line and main
    ("sim/", "sim", 10),                 # a file in sim/ itself: refused (every file of sim/ has its folder)
    ("tests/", "tests", 20),
    ("bench/", "bench", 21),             # bench/flip_bench.cpp uses the test twin tests/sim/metrics/flip_legacy.h
]

# Folders read (relative to the root). Anything under a SKIP folder is ignored.
SCANNED = ["core", "sim", "bench", "tests"]
SKIP = ["tests/tools", "tests/data", "node_modules"]
SOURCE_SUFFIXES = (".h", ".hpp", ".hh", ".inl", ".cpp", ".cc", ".cxx")
# Include directories searched after the including file's folder, in the compiler's order (CMakeLists.txt and
# build/release/compile_commands.json: -Itests before -I<root> for the test executables, -I<root> for the rest).
INCLUDE_DIRS = {"": ["."], "tests/": ["tests", "."]}

# Third-party headers (the start of the path an include writes) -> the layers that may include them (None: any
# layer but those of EXTERNAL_FREE). Embree stays in the scene, Assimp in the importer, the image libraries where
# textures are decoded and frames written, CLI11 in the command line. "sim" (a file left in sim/ itself), tests
# and bench may include them all.
_ANYWHERE = ["sim", "tests", "bench"]
LIBRARIES = {
    "embree": ["scene"] + _ANYWHERE,
    "assimp/": ["assets"] + _ANYWHERE,
    "OpenImageIO/": ["assets", "output"] + _ANYWHERE,
    "OpenEXR/": ["assets", "output"] + _ANYWHERE,
    "Imf": ["assets", "output"] + _ANYWHERE,
    "Imath": ["assets", "output"] + _ANYWHERE,
    "Iex": ["assets", "output"] + _ANYWHERE,
    "CLI/": ["app"] + _ANYWHERE,
    "tbb/": None, "oneapi/tbb": None,
    "nlohmann/": None,
}
# Layers that may include none of LIBRARIES (core/ stands on GLM, Highway and the C++ library: DESIGN §1).
EXTERNAL_FREE = ["core"]
# Layers whose files may not include a given folder at all, whatever its rank (belt and braces for core/).
NEVER = {"core": ["sim/", "bench/", "tests/"]}

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def layer_of(rel):
    best = None
    for folder, name, rank in LAYERS:
        if rel.startswith(folder) and (best is None or len(folder) > len(best[0])):
            best = (folder, name, rank)
    return best


def source_files(root):
    for top in SCANNED:
        base = os.path.join(root, top)
        for dirpath, dirnames, filenames in os.walk(base):
            rel_dir = os.path.relpath(dirpath, root).replace(os.sep, "/")
            dirnames[:] = sorted(d for d in dirnames
                                 if not any((rel_dir + "/" + d).startswith(s) or d == s for s in SKIP))
            for f in sorted(filenames):
                if f.endswith(SOURCE_SUFFIXES):
                    yield (rel_dir + "/" + f) if rel_dir != "." else f


def resolve(root, rel, written):
    """The repository files an include of `written` in `rel` may read, the one the compiler reads first; an empty
    list for a third-party or system header. More than one is an ambiguous include (a test header named like a
    header of sim/ would shadow it)."""
    dirs = INCLUDE_DIRS[""]
    for prefix, ds in INCLUDE_DIRS.items():
        if prefix and rel.startswith(prefix):
            dirs = ds
    found = []
    for d in [os.path.dirname(rel)] + dirs:
        p = os.path.normpath(os.path.join(d, written)).replace(os.sep, "/")
        if not p.startswith("../") and os.path.isfile(os.path.join(root, p)) and p not in found:
            found.append(p)
    return found


def unit_of(rel):
    """foo.h, foo-inl.h and foo.cpp of one folder are one unit."""
    d, f = os.path.split(rel)
    stem = f.rsplit(".", 1)[0]
    if stem.endswith("-inl"):
        stem = stem[:-4]
    return d + "/" + stem


def strongly_connected(nodes, edges):
    """Tarjan's algorithm, iterative. edges: node -> set of nodes. Returns the components of more than one node."""
    index, low, on_stack, stack, comps = {}, {}, set(), [], []
    counter = [0]
    for start in sorted(nodes):
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = counter[0]; counter[0] += 1
        stack.append(start); on_stack.add(start)
        while work:
            v, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]; counter[0] += 1
                    stack.append(w); on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    advanced = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop(); on_stack.discard(w); comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    comps.append(sorted(comp))
    return comps


def layered_order(comp, edges):
    """An order of a loop's units, lowest first, that few of their includes run against (the greedy heuristic of
    Eades, Lin and Smyth 1993 for a small feedback arc set): an include of an earlier unit closes the loop."""
    left = set(comp)
    out = {u: {v for v in edges.get(u, ()) if v in left} for u in comp}
    inc = {u: {v for v in comp if u in out[v]} for u in comp}
    low, high = [], []  # low: units that include nothing left (placed lowest); high: included by nothing left

    def remove(u):
        left.discard(u)
        for v in out[u]:
            inc[v].discard(u)
        for v in inc[u]:
            out[v].discard(u)

    while left:
        progress = True
        while progress:
            progress = False
            for u in sorted(left):
                if not out[u]:
                    low.append(u); remove(u); progress = True
                elif not inc[u]:
                    high.append(u); remove(u); progress = True
        if left:
            u = max(sorted(left), key=lambda x: len(inc[x]) - len(out[x]))
            low.append(u); remove(u)
    return low + list(reversed(high))


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    flags = {a for a in argv[1:] if a.startswith("--")}
    root = os.path.abspath(args[0] if args else ".")
    if "--list-layers" in flags:
        for folder, name, rank in LAYERS:
            print(f"{rank:3d}  {name:10s} {folder}")
        return 0

    problems = []
    unit_edges, unit_lines = {}, {}
    files = list(source_files(root))
    for rel in files:
        own = layer_of(rel)
        if own is None:
            continue
        _, own_name, own_rank = own
        if own_name == "sim":
            problems.append(f"{rel} -- a file of sim/ belongs in the folder of its job (LAYERS), not in sim/ itself")
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
        for number, line in enumerate(lines, 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            quote, written = m.groups()
            where = f"{rel}:{number}: #include {quote}{written}{'>' if quote == '<' else quote}"
            found = resolve(root, rel, written) if quote == '"' else []
            if len(found) > 1:
                problems.append(f"{where} -- ambiguous: the compiler reads {found[0]}, not {', '.join(found[1:])}")
            target = found[0] if found else None
            if target is None:
                for prefix, allowed in LIBRARIES.items():
                    if written.startswith(prefix):
                        if own_name in EXTERNAL_FREE or (allowed is not None and own_name not in allowed):
                            problems.append(f"{where} -- layer {own_name} may not include {prefix}* (third party)")
                        break
                continue
            for folder in NEVER.get(own_name, []):
                if target.startswith(folder):
                    problems.append(f"{where} -- layer {own_name} never includes {folder}")
            other = layer_of(target)
            if other is None:
                continue
            _, other_name, other_rank = other
            if other_rank > own_rank or (other_rank == own_rank and other_name != own_name):
                kind = "a higher layer" if other_rank > own_rank else "a peer"
                problems.append(f"{where} -- layer {own_name} (rank {own_rank}) includes {kind}, "
                                f"{other_name} (rank {other_rank}): {target}")
            if rel.startswith("sim/") and target.startswith("sim/"):
                a, b = unit_of(rel), unit_of(target)
                if a != b:
                    unit_edges.setdefault(a, set()).add(b)
                    unit_lines.setdefault((a, b), []).append(where)

    cycles = []
    if "--no-cycles" not in flags:
        nodes = set(unit_edges) | {b for bs in unit_edges.values() for b in bs}
        for comp in strongly_connected(nodes, unit_edges):
            # Lowest first: by layer, then (within a layer) by a heuristic order few includes run against.
            heuristic = {u: i for i, u in enumerate(layered_order(comp, unit_edges))}
            ranked = sorted(comp, key=lambda u: (layer_of(u + ".h")[2], heuristic[u]))
            order = {u: i for i, u in enumerate(ranked)}
            closing = [line for a in comp for b in sorted(unit_edges.get(a, ()))
                       if b in order and order[b] > order[a] for line in unit_lines[(a, b)]]
            cycles.append((comp, sorted(closing)))

    for p in problems:
        print(p)
    for comp, closing in cycles:
        print("loop of units: " + " <-> ".join(comp))
        for c in closing:
            print(f"  {c}")
    n_loops = len(cycles)
    print(f"{len(files)} files read; {len(problems)} include(s) against the layers; {n_loops} loop(s) of units",
          file=sys.stderr)
    return 1 if problems or cycles else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
