#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The walk of a world's step through the files of src/, read from the static library.

Reads every function's direct calls in address order from `objdump -dr` (relocations to global
functions, and direct calls to the object's own static functions), takes a module to be a file
name without its extensions (as check_symbol_cycles.py does), and walks depth first from
defsim_world_step, expanding each function once. Calls through pointers (the terms' ops, the
backend's table, the host services a backend calls back) are not seen: the walk is the core's
own, around the backend. It prints the modules in the order the walk first enters them and
how often a call enters a module it had entered before (a return to the caller is not counted;
the services below every phase, status, clock, mat3, ..., counted apart).

The machine code's order is the compiler's, not the step's, so the order of the phases is read
from step.c's source: defsim_world_step's calls in source order, with step.c's own static
functions expanded where they are first called (once; a loop's body counts once). Each phase
lists the files it may enter and their functions that step.c calls. With --check it fails
unless step.c's calls go through the phases of src/README.md "A step's walk" (plan -> terms ->
backend -> watchdog -> read-back) exactly, each once and in that order, or when step.c calls a
function that no phase lists, or one that a phase lists under a file that does not define it
(a new call must be placed in the walk).

usage: step_walk.py LIBRARY SRC_DIR [--check] [--trace]
"""
import os
import re
import subprocess
import sys

ROOT = 'defsim_world_step'
# Functions of the services that step.c calls anywhere (errors, the clock).
SERVICES_FN = {'defsim__error', 'defsim__now', 'defsim_status_string'}
# Modules below every phase: called from anywhere, they order nothing.
SERVICES = {'status', 'clock', 'mat3', 'options', 'host', 'system', 'element'}
# The phases of src/README.md "A step's walk": per phase, the files it enters and the functions
# of each that step.c calls.
PHASES = [
    ('plan', {'world': ['defsim__world_enter', 'defsim__world_plan',
                        'defsim__world_backend_prepare']}),
    ('terms', {'terms': ['defsim__terms_step_begin']}),
    ('backend', {'stability': ['defsim__omega_max', 'defsim__damping_coeff'],
                 'options': ['defsim__options_values'],
                 'terms': ['defsim__terms_substep_before', 'defsim__terms_substep_after',
                           'defsim__terms_restart', 'defsim__terms_finish']}),
    ('watchdog', {'watchdog': ['defsim__watchdog_pin_buffer', 'defsim__watchdog_pin_forces',
                               'defsim__watchdog_check', 'defsim__watchdog_message']}),
    ('read-back', {'terms': ['defsim__terms_step_end'],
                   'world': ['defsim__world_backend_stop'],
                   'watchdog': ['defsim__watchdog_step_done']}),
]


def source_calls(path):
    """step.c's functions and the identifiers each calls, in source order."""
    text = open(path).read()
    text = re.sub(r'/\*.*?\*/', ' ', text, flags=re.S)
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    funcs, i = {}, 0
    for m in re.finditer(r'^[A-Za-z_][\w \*]*?\b([A-Za-z_]\w*)\s*\([^;{]*?\)\s*\{', text,
                         flags=re.M | re.S):
        if m.start() < i:
            continue
        depth, j = 1, m.end()
        while depth and j < len(text):
            depth += {'{': 1, '}': -1}.get(text[j], 0)
            j += 1
        funcs[m.group(1)] = re.findall(r'\b([A-Za-z_]\w*)\s*\(', text[m.end():j])
        i = j
    return funcs


def source_walk(path, defined, modules):
    """defsim_world_step's calls into other files in source order (static ones expanded)."""
    funcs, seen, out = source_calls(path), set(), []

    def visit(name):
        seen.add(name)
        for callee in funcs.get(name, ()):
            if callee in funcs:
                if callee not in seen:
                    visit(callee)
            elif any(m in modules for m in defined.get(callee, ())):
                out.append(callee)

    visit(ROOT)
    return out


def module_of(member):
    return os.path.basename(member).split('.', 1)[0]


def read_calls(lib):
    out = subprocess.run(['objdump', '-dr', lib], check=True, capture_output=True,
                         text=True).stdout
    calls, defined = {}, {}
    mod, fn, pending = None, None, False
    for line in out.splitlines():
        m = re.match(r'^(\S+\.o):\s+file format', line)
        if m:
            mod, fn = module_of(m.group(1)), None
            continue
        m = re.match(r'^[0-9a-f]+ <([^>]+)>:$', line)
        if m and mod:
            fn = (mod, m.group(1))
            calls.setdefault(fn, [])
            defined.setdefault(m.group(1), set()).add(mod)
            continue
        if fn is None:
            continue
        m = re.search(r'\t(call|jmp)\s+[0-9a-f]+ <([^>+]+)(\+0x[0-9a-f]+)?>', line)
        if m:
            pending = True
            if not m.group(3) and m.group(2) != fn[1]:   # a static function of this object
                calls[fn].append((mod, m.group(2), True))
                pending = False
            continue
        m = re.search(r'R_X86_64_(?:PLT32|PC32)\s+([A-Za-z_][\w.]*)', line)
        if m and pending:
            if not m.group(1).startswith('.'):
                calls[fn].append((None, m.group(1), False))
            pending = False
        elif not line.startswith('\t\t\t'):
            pending = False
    return calls, defined


def walk(calls, defined, modules):
    seen, order, entries, trace = set(), [], {}, []

    def resolve(mod, name, local):
        if local:
            return (mod, name)
        owners = [m for m in defined.get(name, ()) if m in modules]
        return (owners[0], name) if owners else None

    def visit(fn):
        seen.add(fn)
        for mod, name, local in calls.get(fn, ()):
            target = resolve(mod or fn[0], name, local)
            if target is None or target in seen:
                continue
            if target[0] != fn[0]:
                entries[target[0]] = entries.get(target[0], 0) + 1
                trace.append((fn[0], target[0], target[1]))
                if target[0] not in order:
                    order.append(target[0])
            visit(target)

    sys.setrecursionlimit(100000)
    root = resolve(None, ROOT, False)
    order.append(root[0])
    entries[root[0]] = 1
    visit(root)
    return order, entries, trace


def main():
    args = [a for a in sys.argv[1:] if not a.startswith('--')]
    if len(args) < 2:
        print(__doc__)
        return 2
    lib, src = args
    modules = {f.split('.', 1)[0] for f in os.listdir(src) if f.endswith(('.c', '.h'))}
    calls, defined = read_calls(lib)
    order, entries, trace = walk(calls, defined, modules)
    again = sum(n - 1 for n in entries.values())
    core = [m for m in order if m not in SERVICES]
    again_core = sum(entries[m] - 1 for m in core)
    print('modules entered: %d (%d without the services %s)' %
          (len(order), len(core), ', '.join(sorted(SERVICES))))
    print('calls into a module entered before: %d (%d without the services)' %
          (again, again_core))
    print('first entries: ' + ' -> '.join(order))
    print('entries per module: ' + ', '.join('%s %d' % (m, entries[m]) for m in order))
    if '--trace' in sys.argv:
        for a, b, f in trace:
            print('  %s -> %s (%s)' % (a, b, f))
    step_src = os.path.join(src, 'step.c')
    seq = source_walk(step_src, defined, modules)
    mods = [next(iter(defined[f])) for f in seq if f not in SERVICES_FN]
    runs = [m for i, m in enumerate(mods) if i == 0 or m != mods[i - 1]]
    print('step.c in source order, the files it calls (runs): ' + ' -> '.join(runs))
    phase = {f: (i, m) for i, (_, files) in enumerate(PHASES) for m, fs in files.items()
             for f in fs}
    calls = [f for f in seq if f not in SERVICES_FN]
    names = [PHASES[phase[f][0]][0] if f in phase else '?' for f in calls]
    phase_runs = [p for i, p in enumerate(names) if i == 0 or p != names[i - 1]]
    files = {}
    for f, p in zip(calls, names):
        m = next(iter(defined.get(f, ('?',))))
        if m not in files.setdefault(p, []):
            files[p].append(m)
    print('step.c in source order, the phases it goes through (their files): ' +
          ' -> '.join('%s (%s)' % (p, ', '.join(files[p])) for p in phase_runs))
    if '--check' in sys.argv:
        bad = []
        for f in dict.fromkeys(calls):
            if f not in phase:
                bad.append('step.c calls %s, which no phase of the walk lists' % f)
            elif phase[f][1] not in defined.get(f, ()):
                bad.append('%s is listed under %s (%s), which does not define it' %
                           (f, phase[f][1], PHASES[phase[f][0]][0]))
        want = [p for p, _ in PHASES]
        if phase_runs != want:
            bad.append('the phases go %s, not %s, each once' %
                       (' -> '.join(phase_runs), ' -> '.join(want)))
        for b in bad:
            print('out of the walk\'s order: ' + b)
        if bad:
            return 1
        print('the phases in order, each once: ' + ' -> '.join(want))
    return 0


if __name__ == '__main__':
    sys.exit(main())
