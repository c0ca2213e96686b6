#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Fails when the files of src/ call each other in a cycle.

Reads the defined and undefined symbols of every object file in the static library (nm), takes
a module to be a file name without its extensions (world.c and world.h are module "world"; the
per-instruction-set compiles of a file count as that file), draws an edge A -> B for each symbol
that A uses and B defines, and reports every cycle it finds (a strongly connected component of
more than one module). Includes alone cannot see a cycle when a header declares another file's
functions; the linker's view can.

usage: check_symbol_cycles.py LIBRARY SRC_DIR [--print-graph]
"""
import os
import re
import subprocess
import sys


def module_of(member):
    return member.split('.', 1)[0]


def read_symbols(lib):
    out = subprocess.run(['nm', '-A', '-P', lib], check=True, capture_output=True,
                         text=True).stdout
    defined, used = {}, {}
    for line in out.splitlines():
        # "lib.a[world.c.o]: defsim_world_step T 0000 0010" (POSIX format with -A)
        m = re.match(r'^(?:.*\[(?P<member>[^\]]+)\]|(?P<file>[^:]+)):\s+(?P<sym>\S+)\s+(?P<t>\S)',
                     line)
        if not m:
            continue
        member = m.group('member') or os.path.basename(m.group('file'))
        mod = module_of(member)
        sym, t = m.group('sym'), m.group('t')
        if t == 'U':
            used.setdefault(mod, set()).add(sym)
        elif t in 'TDBRVWGSCi':   # global definitions (lower case: local)
            defined.setdefault(sym, set()).add(mod)
    return defined, used


def graph(defined, used, modules):
    edges = {m: set() for m in modules}
    for mod, syms in used.items():
        if mod not in modules:
            continue
        for s in syms:
            for owner in defined.get(s, ()):
                if owner != mod and owner in modules:
                    edges[mod].add(owner)
    return edges


def cycles(edges):
    """Tarjan's strongly connected components of more than one module."""
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def one_cycle(edges, comp):
    """A shortest closed path through the component's first module, for the message."""
    start = comp[0]
    members = set(comp)
    prev, frontier = {start: None}, [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(edges[v]):
                if w not in members:
                    continue
                if w == start:
                    path = [v]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return list(reversed(path)) + [start]
                if w not in prev:
                    prev[w] = v
                    nxt.append(w)
        frontier = nxt
    return comp


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    lib, src = sys.argv[1], sys.argv[2]
    modules = {f.split('.', 1)[0] for f in os.listdir(src) if f.endswith(('.c', '.h'))}
    defined, used = read_symbols(lib)
    edges = graph(defined, used, modules)
    if '--print-graph' in sys.argv:
        for m in sorted(edges):
            if edges[m]:
                print(f'{m}: {" ".join(sorted(edges[m]))}')
    found = cycles(edges)
    for comp in found:
        print('call cycle among src/ files: ' + ' -> '.join(one_cycle(edges, comp)) +
              f'  (strongly connected: {", ".join(comp)})')
    if found:
        return 1
    n = sum(len(e) for e in edges.values())
    print(f'no call cycle: {len([m for m in modules if m in used])} objects, {n} edges')
    return 0


if __name__ == '__main__':
    sys.exit(main())
