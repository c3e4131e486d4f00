"""The package's imports run one way: no module reaches, even through a
function-level import, a module that imports it back; and its modules and
functions stay small enough to read (issue 41's limits)."""
import ast
import functools
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


@functools.cache      # read-only for the tests; parsing every module is most of their time
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


# Floors, bottom first: a module imports from its own floor or those below.
# kernels/ is the shared toolkit and imports nothing of raytrace above it.
FLOORS = ["kernels", "errors", "accel", "options", "scene", "renderer", "cast", "frames", "cli",
          "raytrace"]


def floor(module):
    parts = module.split(".")
    return "raytrace" if len(parts) == 1 or parts[1] in ("__main__",) else parts[1]


def test_every_module_has_a_floor():
    assert {floor(m) for m in graph()} <= set(FLOORS)


def test_imports_run_down_the_floors():
    up = [f"{a} -> {b}" for a, bs in graph().items() for b in bs
          if FLOORS.index(floor(b)) > FLOORS.index(floor(a))]
    assert not up, "imports running up: " + "; ".join(sorted(up))


def test_kernels_import_only_kernels():
    out = [f"{a} -> {b}" for a, bs in graph().items() if floor(a) == "kernels" for b in bs
           if floor(b) != "kernels"]
    assert not out, out


def structure_folder(module):
    parts = module.split(".")
    return parts[2] if len(parts) > 3 and parts[1] == "accel" else None


def test_structures_are_folders_in_the_registry():
    """Each structure is one folder of raytrace/accel with its build and
    traversal, named by one registry entry; no other folder is there."""
    from raytrace.accel.registry import STRUCTURES
    folders = {p.name for p in (PKG / "accel").iterdir() if (p / "__init__.py").exists()}
    assert folders == {s.module for s in STRUCTURES.values()}
    for name in folders:
        assert (PKG / "accel" / name / "build.py").exists()
        assert (PKG / "accel" / name / "traverse.py").exists()


def test_structure_folders_do_not_import_each_other_in_a_loop():
    edges = {}
    for a, bs in graph().items():
        for b in bs:
            fa, fb = structure_folder(a), structure_folder(b)
            if fa and fb and fa != fb:
                edges.setdefault(fa, set()).add(fb)
    for a, bs in edges.items():
        for b in bs:
            assert a not in edges.get(b, set()), f"structures {a} and {b} import each other"


MAX_MODULE_LINES = 600
MAX_PARAMETERS = 12


def test_modules_and_functions_stay_small():
    """No module over 600 lines and no function over 12 parameters (*args
    and **kwargs count one each): what travels together goes as a record
    (kernels/render.py's Render and Band, cli/params.py's SceneArgs)."""
    too_long, too_many = [], []
    for path in PKG.rglob("*.py"):
        text = path.read_text()
        if text.count("\n") > MAX_MODULE_LINES:
            too_long.append(str(path.relative_to(PKG)))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                a = node.args
                n = (len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                     + (a.vararg is not None) + (a.kwarg is not None))
                if n > MAX_PARAMETERS:
                    too_many.append(f"{path.relative_to(PKG)}:{node.lineno} ({n})")
    assert not too_long, f"modules over {MAX_MODULE_LINES} lines: {too_long}"
    assert not too_many, f"functions over {MAX_PARAMETERS} parameters: {too_many}"
