"""The layering the architecture promises (docs/architecture.md), checked on the built objects
and the sources:
- no two files of a library call each other through a chain of calls (a cycle among its object
  files), and the libraries depend on each other one way (libopaline on none of the others;
  dataset and methods not on each other);
- no module includes a module that includes it back (x_internal.h counts as part of x);
- a header of another top-level folder is included only from include/ (the tests, which reach
  private headers to test modules directly, are not checked);
- the C programs of bench/ use the libraries only through the public headers: every symbol of
  a library that a bench object uses is named in include/;
- the renderer's folders keep their direction: the subsurface code (renderer/lib/sss/) reaches
  the integrator neither by an include (directly or through other headers) nor by a call
  (directly or through other objects of the library); the integrator hands it the light
  transport (op_sss_transport), as a BSSRDF leaves tracing to the integrator;
- the renderer reads materials and never writes them (no include of opaline_material_write.h,
  directly or not, and no call of the writer's functions);
- no Python module of the add-on, cluster/ or bench/ imports a module that imports it back,
  counting imports inside functions (they are a file-level dependency all the same).
Usage: layering.py SOURCE_DIR BUILD_DIR."""
import ast
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
# The C sources checked (each folder with its subfolders); tests/ is not among them.
SOURCE_DIRS = ['include', 'libopaline', 'factorize', 'renderer', 'bench']
PUBLIC_HEADERS = 'include'
# Programs whose objects may use the libraries only through the public headers.
PUBLIC_ONLY_DIRS = ['bench']
# The exceptions, each a measurement of one internal routine at full size (as a test reaches a
# module directly): program -> the private headers it may include. Its uses of the libraries
# are then checked against include/ and these headers.
BENCH_PRIVATE = {
    'bench/bench_rsvd.c': {'factorize/methods/rsvd.h'},  # the svd method's SVD vs scikit-learn
    'bench/bench_sss_reference.c': {'tests/c/mc_reference.h', 'tests/c/test_support.h'},
}
# (folder, folder it must not reach, why): by includes and by calls, directly or not.
FOLDER_RULES = [
    ('renderer/lib/sss', 'renderer/lib/integrator',
     'the subsurface code is passive: it traces through the op_sss_transport it is given'),
]
# The material writer's public header and its functions' prefixes, which the renderer never uses.
WRITER_HEADER = 'opaline_material_write.h'
WRITER_PREFIXES = ('op_material_writer_', 'op_write_')
# Python import roots (folder, the packages and modules under it that are checked).
PYTHON_ROOTS = [('blender_addon', ['opaline']), ('cluster', None), ('bench', None)]


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


def reach(graph, start):
    """The nodes reachable from start (start excluded unless on a cycle), with the path to each."""
    paths, todo = {}, [(start, [start])]
    while todo:
        v, path = todo.pop()
        for w in sorted(graph.get(v, ())):
            if w not in paths:
                paths[w] = path + [w]
                todo.append((w, path + [w]))
    return paths


def nm_symbols(path):
    """{object: (defined, undefined)} of a static archive or an object file."""
    out = subprocess.run(['nm', '-A', path], capture_output=True, text=True, check=True).stdout
    objs = {}
    for line in out.splitlines():
        m = re.match(r'(?:[^:]+:)?([^:]+):\s*(?:[0-9a-f]+)?\s+([A-Za-z])\s+(\S+)$', line)
        if not m:
            continue
        obj, kind, sym = m.groups()
        d, u = objs.setdefault(os.path.basename(obj).replace('.c.o', ''), (set(), set()))
        if kind == 'U':
            u.add(sym)
        elif kind in 'TDBRV':
            d.add(sym)
    return objs


def c_files(src):
    """Every C source and header of SOURCE_DIRS, as paths relative to src."""
    files = []
    for d in SOURCE_DIRS:
        for f in glob.glob(os.path.join(src, d, '**', '*.[ch]'), recursive=True):
            files.append(os.path.relpath(f, src))
    return sorted(files)


def resolve(rel, inc, headers):
    """The header `#include "inc"` in file rel names: beside rel, else in rel's top-level
    folder, else in include/, else anywhere (None when no such header is in the sources)."""
    own = os.path.normpath(os.path.join(os.path.dirname(rel), inc))
    if own in headers:
        return own
    found = sorted(h for h in headers if h.endswith('/' + inc))
    top = rel.split('/')[0]
    for pick in ([h for h in found if h.split('/')[0] == top],
                 [h for h in found if h.split('/')[0] == PUBLIC_HEADERS], found):
        if pick:
            return pick[0]
    return None


def check_libraries(build, failures):
    """The archives: cycles among a library's objects, libraries used one way."""
    owner_lib, per_lib = {}, {}
    for rel in LIBS:
        path = os.path.join(build, rel)
        if not os.path.exists(path):
            failures.append(f'{rel}: not built')
            continue
        name = os.path.basename(rel)[:-2]
        per_lib[name] = nm_symbols(path)
        for obj, (d, _) in per_lib[name].items():
            for s in d:
                owner_lib[s] = name
    graphs = {}
    for name, objs in per_lib.items():
        owner = {s: o for o, (d, _) in objs.items() for s in d}
        graphs[name] = {o: {owner[s] for s in u if s in owner and owner[s] != o}
                        for o, (_, u) in objs.items()}
        for c in cycles(graphs[name]):
            failures.append(f'{name}: files call each other in a cycle: {" -> ".join(c)}')
        allowed = next(v for k, v in LIBS.items() if os.path.basename(k)[:-2] == name)
        for o, (_, u) in objs.items():
            for s in sorted(u):
                other = owner_lib.get(s)
                if other and other != name and other not in allowed:
                    failures.append(f'{name}: {o} uses {s} of {other}')
    return per_lib, owner_lib, graphs


def check_includes(src, files, failures):
    """Include cycles and includes across top-level folders; returns the include graph
    between files."""
    headers = {f for f in files if f.endswith('.h')}
    test_headers = {os.path.relpath(h, src) for h in
                    glob.glob(os.path.join(src, 'tests', '**', '*.h'), recursive=True)}
    includes = {}
    for f in files:
        with open(os.path.join(src, f), encoding='utf-8') as fh:
            names = re.findall(r'^\s*#\s*include\s+"([^"]+)"', fh.read(), re.M)
        includes[f] = set()
        for inc in names:
            h = resolve(f, inc, headers)
            if h is None:
                h = resolve(f, inc, test_headers)  # the tests' headers: never shared
                if h is None:
                    continue
            else:
                includes[f].add(h)
            top, htop = f.split('/')[0], h.split('/')[0]
            if htop != top and htop != PUBLIC_HEADERS and h not in BENCH_PRIVATE.get(f, ()):
                failures.append(f'{f} includes {h}: a header of another top-level folder '
                                f'(only {PUBLIC_HEADERS}/ is shared)')

    def module(path):
        return re.sub(r'_internal$', '', os.path.splitext(path)[0])

    graph = {}
    for f, hs in includes.items():
        graph.setdefault(module(f), set()).update(module(h) for h in hs if module(h) != module(f))
    for c in cycles(graph):
        failures.append(f'modules include each other: {" -> ".join(c)}')
    return includes, len(graph)


def check_public_only(src, build, files, owner_lib, failures):
    """The objects of PUBLIC_ONLY_DIRS use of the libraries only what include/ names."""
    def names(rel):
        with open(os.path.join(src, rel), encoding='utf-8') as fh:
            return set(re.findall(r'\w+', fh.read()))

    public = set()
    for f in files:
        if f.startswith(PUBLIC_HEADERS + '/'):
            public |= names(f)
    checked = 0
    for d in PUBLIC_ONLY_DIRS:
        sources = [f for f in files if f.startswith(d + '/') and f.endswith('.c')]
        for f in sources:
            obj = glob.glob(os.path.join(build, d, '**', os.path.basename(f) + '.o'),
                            recursive=True)
            if not obj:
                failures.append(f'{f}: not built')
                continue
            checked += 1
            allowed = public.union(*(names(h) for h in BENCH_PRIVATE.get(f, ())))
            for _, (_, undefined) in nm_symbols(obj[0]).items():
                for s in sorted(undefined):
                    if s in owner_lib and s not in allowed:
                        failures.append(f'{f} uses {s} of {owner_lib[s]}, which '
                                        f'{PUBLIC_HEADERS}/ does not declare')
    return checked


def check_folders(src, files, includes, per_lib, graphs, failures):
    """FOLDER_RULES, by includes and by calls."""
    for frm, to, why in FOLDER_RULES:
        for f in files:
            if not f.startswith(frm + '/'):
                continue
            for h, path in sorted(reach(includes, f).items()):
                if h.startswith(to + '/'):
                    failures.append(f'{f} reaches {to}/ by includes ({" -> ".join(path)}): {why}')
                    break
        # objects are named by their source's base name, one per name in a library
        lib_dir = os.path.commonpath([frm, to])
        sources = {}
        for f in files:
            if f.startswith(lib_dir + '/') and f.endswith('.c'):
                base = os.path.splitext(os.path.basename(f))[0]
                if base in sources:
                    failures.append(f'{f} and {sources[base]} share a name: their objects '
                                    f'collide in the archive')
                sources[base] = f
        for name, objs in per_lib.items():
            if not any(sources.get(o, '').startswith(frm + '/') for o in objs):
                continue
            for o in sorted(objs):
                if not sources.get(o, '').startswith(frm + '/'):
                    continue
                for w, path in sorted(reach(graphs[name], o).items()):
                    if sources.get(w, '').startswith(to + '/'):
                        failures.append(f'{sources[o]} reaches {to}/ by calls '
                                        f'({" -> ".join(path)}): {why}')
                        break


def python_modules(root, only):
    """{dotted name: file} of the Python modules under root (only: the top-level packages or
    modules to take, None for all)."""
    mods = {}
    for f in glob.glob(os.path.join(root, '**', '*.py'), recursive=True):
        parts = os.path.relpath(f, root)[:-3].split(os.sep)
        if only is not None and parts[0] not in only:
            continue
        if parts[-1] == '__init__':
            parts = parts[:-1]
        if parts:
            mods['.'.join(parts)] = f
    return mods


def python_imports(name, path, mods):
    """The modules of mods that module `name` (file path) imports, anywhere in the file."""
    with open(path, encoding='utf-8') as fh:
        tree = ast.parse(fh.read(), path)
    package = name if path.endswith('__init__.py') else name.rpartition('.')[0]
    out = set()

    def add(target):
        while target and target not in mods:  # a name inside a module: that module
            target = target.rpartition('.')[0]
        if target and target != name:
            out.add(target)

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split('.') if package else []
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                base = '.'.join(base + ([node.module] if node.module else []))
            else:
                base = node.module or ''
            for a in node.names:
                full = f'{base}.{a.name}' if base else a.name
                add(full if full in mods else base)
    return out


def check_python(src, failures):
    """Import cycles in each of PYTHON_ROOTS; returns the count of modules checked."""
    count = 0
    for root, only in PYTHON_ROOTS:
        mods = python_modules(os.path.join(src, root), only)
        count += len(mods)
        graph = {m: python_imports(m, f, mods) for m, f in mods.items()}
        for c in cycles(graph):
            failures.append(f'{root}/: Python modules import each other: {" -> ".join(c)}')
    return count


def check_reader_only(src, files, includes, per_lib, failures):
    """The renderer reads materials and never writes them: none of its files reaches the
    writer's header by includes, and its archive calls none of the writer's functions."""
    for f in files:
        if f.startswith('renderer/') and 'include/' + WRITER_HEADER in reach(includes, f):
            failures.append(f'{f} reaches include/{WRITER_HEADER}: the renderer only reads '
                            'materials')
    for o, (_, undefined) in sorted(per_lib.get('libopaline_render', {}).items()):
        for s in sorted(undefined):
            if s.startswith(WRITER_PREFIXES):
                failures.append(f'libopaline_render: {o} calls {s}: the renderer only reads '
                                'materials')


def main():
    src, build = sys.argv[1], sys.argv[2]
    failures = []
    files = c_files(src)
    per_lib, owner_lib, graphs = check_libraries(build, failures)
    includes, nmodules = check_includes(src, files, failures)
    nprograms = check_public_only(src, build, files, owner_lib, failures)
    check_folders(src, files, includes, per_lib, graphs, failures)
    check_reader_only(src, files, includes, per_lib, failures)
    npython = check_python(src, failures)
    for f in failures:
        print('layering:', f)
    checked = sum(len(o) for o in per_lib.values())
    print(f'layering: {checked} objects in {len(per_lib)} libraries, {nmodules} C modules, '
          f'{nprograms} bench objects, {npython} Python modules: {len(failures)} problems')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
