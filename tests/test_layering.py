"""The package's imports run one way: no module reaches, even through a
function-level import, a module that imports it back."""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "raytrace"


def module_name(path):
    parts = path.relative_to(PKG.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path, modules):
    """raytrace modules a file imports, at any depth of its code: for
    ``from X import name`` the module X.name if there is one, else X."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in modules else mod
                       for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            continue
        out |= {t for t in targets if t.startswith("raytrace")}
    return out


def graph():
    files = {module_name(p): p for p in PKG.rglob("*.py")}
    edges = {}
    for name, path in files.items():
        # An import of a package imports its __init__; keep only real modules.
        edges[name] = {t for t in imports(path, files) if t in files and t != name}
    return edges


def test_no_import_cycles():
    edges = graph()
    state, path = {}, []

    def visit(n):
        state[n] = "open"
        path.append(n)
        for m in sorted(edges[n]):
            if state.get(m) == "open":
                raise AssertionError("import cycle: " + " -> ".join(path[path.index(m):] + [m]))
            if m not in state:
                visit(m)
        path.pop()
        state[n] = "done"

    for n in sorted(edges):
        if n not in state:
            visit(n)
