"""The layering the architecture promises (docs/architecture.md), checked on the built objects
and the sources: no two files of a library call each other through a chain of calls (a cycle
among its object files), the libraries depend on each other one way (libopaline on none of the
others; dataset and methods not on each other), and no module includes a module that includes
it back (x_internal.h counts as part of x). Usage: layering.py SOURCE_DIR BUILD_DIR."""
import glob
import os
import re
import subprocess
import sys

LIBS = {  # archive (relative to the build folder) -> the libraries it may use
    'libopaline/libopaline.a': set(),
    'factorize/libopaline_dataset.a': {'libopaline'},
    'factorize/libopaline_methods.a': {'libopaline'},
    'factorize/libopaline_factor.a': {'libopaline', 'libopaline_dataset', 'libopaline_methods'},
    'renderer/libopaline_render.a': {'libopaline'},
}
SOURCE_DIRS = ['libopaline', 'include', 'factorize/dataset', 'factorize/methods', 'factorize/cli',
               'renderer/lib', 'renderer/cli']


def cycles(graph):
    """Every cycle found by a depth-first search, each as a list of nodes."""
    state, stack, found = {}, [], []

    def visit(v):
        state[v] = 1
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if state.get(w) == 1:
                found.append(stack[stack.index(w):] + [w])
            elif not state.get(w):
                visit(w)
        stack.pop()
        state[v] = 2

    for v in sorted(graph):
        if not state.get(v):
            visit(v)
    return found


def archive_symbols(path):
    """{object: (defined, undefined)} of a static archive."""
    out = subprocess.run(['nm', '-A', path], capture_output=True, text=True, check=True).stdout
    objs = {}
    for line in out.splitlines():
        m = re.match(r'[^:]+:([^:]+):\s*(?:[0-9a-f]+)?\s+([A-Za-z])\s+(\S+)$', line)
        if not m:
            continue
        obj, kind, sym = m.groups()
        d, u = objs.setdefault(obj.replace('.c.o', ''), (set(), set()))
        if kind == 'U':
            u.add(sym)
        elif kind in 'TDBRV':
            d.add(sym)
    return objs


def main():
    src, build = sys.argv[1], sys.argv[2]
    failures = []
    owner_lib, per_lib = {}, {}
    for rel in LIBS:
        path = os.path.join(build, rel)
        if not os.path.exists(path):
            failures.append(f'{rel}: not built')
            continue
        name = os.path.basename(rel)[:-2]
        per_lib[name] = archive_symbols(path)
        for obj, (d, _) in per_lib[name].items():
            for s in d:
                owner_lib[s] = name
    for name, objs in per_lib.items():
        owner = {s: o for o, (d, _) in objs.items() for s in d}
        graph = {o: {owner[s] for s in u if s in owner and owner[s] != o}
                 for o, (_, u) in objs.items()}
        for c in cycles(graph):
            failures.append(f'{name}: files call each other in a cycle: {" -> ".join(c)}')
        allowed = next(v for k, v in LIBS.items() if os.path.basename(k)[:-2] == name)
        for o, (_, u) in objs.items():
            for s in sorted(u):
                other = owner_lib.get(s)
                if other and other != name and other not in allowed:
                    failures.append(f'{name}: {o} uses {s} of {other}')
    modules = {}
    for d in SOURCE_DIRS:
        for f in glob.glob(os.path.join(src, d, '**', '*.[ch]'), recursive=True):
            m = re.sub(r'_internal$', '', os.path.splitext(os.path.basename(f))[0])
            with open(f, encoding='utf-8') as fh:
                inc = re.findall(r'#include "([^"]+)\.h"', fh.read())
            modules.setdefault(m, set()).update(re.sub(r'_internal$', '', i) for i in inc)
    graph = {m: {i for i in v if i in modules and i != m} for m, v in modules.items()}
    for c in cycles(graph):
        failures.append(f'modules include each other: {" -> ".join(c)}')
    for f in failures:
        print('layering:', f)
    checked = sum(len(o) for o in per_lib.values())
    print(f'layering: {checked} objects in {len(per_lib)} libraries, {len(modules)} modules: '
          f'{len(failures)} problems')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
