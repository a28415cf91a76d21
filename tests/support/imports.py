"""surfgrad's import graph read from the source (ast), never by importing: which of our modules
each file imports, function-level (lazy) imports included, relative imports resolved."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "surfgrad_addon"
BLENDER_MODULES = {"bpy", "_bpy", "mathutils", "bmesh", "bpy_extras", "bpy_types", "gpu",
                   "gpu_extras", "bl_math", "aud", "idprop", "imbuf", "freestyle"}


def module_name(path, root):
    """Dotted name of a .py file under root ('surfgrad_addon/addon/__init__.py' ->
    'surfgrad_addon.addon')."""
    parts = list(Path(path).relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(source, name, is_package):
    """What a module's source imports, as (module, names) pairs with absolute module names:
    `import a.b` gives ('a.b', ()); `from a import b, c` gives ('a', ('b', 'c'))."""
    package = name.split(".") if is_package else name.split(".")[:-1]
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out.extend((alias.name, ()) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            out.append((module, tuple(a.name for a in node.names if a.name != "*")))
    return out


def _files(root, package, files):
    root = Path(root)
    files = sorted(files if files is not None else (root / package).rglob("*.py"))
    return {module_name(f, root): Path(f) for f in files}


def graph(root=ROOT, package=PACKAGE, files=None):
    """{module: set of our modules it imports} for every .py under root/package (or the given
    files, paths under root). `from a import b` is an edge to a.b when that is one of our
    modules (a module imported from its package), else to a; `import a.b.c` goes to the
    longest of our modules it names. A name of ours that is no module stays as it is, so a
    check can name it."""
    names = _files(root, package, files)

    def ours(m):
        parts = m.split(".")
        for k in range(len(parts), 0, -1):
            if ".".join(parts[:k]) in names:
                return ".".join(parts[:k])
        return m

    edges = {}
    for name, f in names.items():
        targets = set()
        for module, members in imports(f.read_text(), name, f.name == "__init__.py"):
            if module.split(".")[0] != package:
                continue
            subs = [f"{module}.{m}" for m in members if f"{module}.{m}" in names]
            targets.update(subs)
            if not members or len(subs) < len(members):
                targets.add(ours(module))
        edges[name] = targets - {name}
    return edges


def third_party(root=ROOT, package=PACKAGE, files=None):
    """{module: top-level names of the other packages it imports} (bpy, numpy, ...)."""
    out = {}
    for name, f in _files(root, package, files).items():
        out[name] = {m.split(".")[0] for m, _ in imports(f.read_text(), name,
                                                         f.name == "__init__.py")
                     if m.split(".")[0] != package}
    return out


def cycles(edges):
    """Strongly connected groups of more than one module (Tarjan), each sorted."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in edges:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found
