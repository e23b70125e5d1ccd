"""The Python package's layers: no import cycle, and every import goes down (or sideways) in LAYERS.

Every module of model/fringe is parsed (not imported): module-level and function-local imports, relative and
absolute, all count, since a function-local import only defers the cycle to the first call.
"""

import ast
from pathlib import Path

import pytest

PACKAGE_ROOT = Path(__file__).resolve().parents[1] / "model"

#: Lowest first: a module may import its own layer and the layers below, never one above. A module is named
#: exactly, or as a package's module (`fringe.fixed.*`); the exact name wins. Each layer is a package of its own
#: but for the base (the top-level modules) and the engines (`fringe.cli.engines`).
LAYERS = [
    # what everything shares: the errors users see, the encoder description, the engines' result and status bits
    ("base", ["fringe", "fringe.errors", "fringe.encoder", "fringe.result"]),
    # bit-exact models of the RTL blocks, one module per block (the HDL's names, limits and messages)
    ("fixed", ["fringe.fixed.*"]),
    # the float signal model: encoder simulator, fits, the calibration's stages, the loop's effect library
    ("dsp", ["fringe.dsp.*"]),
    # files: recordings, safe outputs, calibration folders, the shared data sets
    ("io", ["fringe.io.*"]),
    # from a calibration to the core: configuration, tables, ROM images, the RTL in simulation
    ("hardware", ["fringe.hardware.*"]),
    # the float engine (its drift tracker runs the core's equations on the hardware's tables)
    ("engine", ["fringe.engine.*"]),
    # fitting a recording and judging a correction
    ("calibration", ["fringe.calib.*"]),
    # the closed loop, its scenarios and its report
    ("loop", ["fringe.loop.*"]),
    # the engines behind `fringe correct`
    ("engines", ["fringe.cli.engines"]),
    ("cli", ["fringe.cli.*", "fringe.__main__"]),
    # benchmarks, the closed loop's population and the demo, which drive the command line
    ("tools", ["fringe.tools.*"]),
]

#: what the bit-exact models may import from outside fringe.fixed
FIXED_MAY_IMPORT = {"fringe.encoder", "fringe.result"}

#: the closed loop's modules, lowest first: each imports only the ones before it (the scenarios stand alone)
LOOP_ORDER = ["fringe.loop.scenarios", "fringe.loop.motion", "fringe.loop.evaluation", "fringe.loop.noise",
              "fringe.loop.significance", "fringe.loop.tones", "fringe.loop.candidates", "fringe.loop.refit",
              "fringe.loop.amplitude", "fringe.loop.run", "fringe.loop.report"]


def modules(root: Path = PACKAGE_ROOT) -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package) for every module under root/fringe."""
    out = {}
    for path in sorted((root / "fringe").rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


def imports(root: Path = PACKAGE_ROOT):
    """(module, imported module, names) for every import statement anywhere in a module's text: `import a.b`
    gives ("a.b", []), `from .x import y` the absolute name of x and ["y"]."""
    for name, (path, is_package) in modules(root).items():
        here = name.split(".") if is_package else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                yield from ((name, a.name, []) for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                parent = here[:len(here) - node.level + 1] if node.level else []
                yield name, ".".join(parent + ([node.module] if node.module else [])), [a.name for a in node.names]


def import_graph(root: Path = PACKAGE_ROOT) -> dict[str, set[str]]:
    """Module -> the fringe modules it imports (`from . import x` names x if it is a module, else the package)."""
    mods = modules(root)
    graph = {name: set() for name in mods}
    for name, base, names in imports(root):
        targets = [f"{base}.{n}" if f"{base}.{n}" in mods else base for n in names] or [base]
        graph[name].update(t for t in targets if t.split(".")[0] == "fringe" and t != name)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def defined_names(tree: ast.Module) -> set[str]:
    """Names a module defines itself at top level (functions, classes, assignments), not the ones it imports."""
    names, todo = set(), list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.If, ast.Try)):
            todo += node.body + node.orelse + getattr(node, "finalbody", []) + [
                s for h in getattr(node, "handlers", []) for s in h.body]
    return names


def borrowed_names(root: Path = PACKAGE_ROOT) -> list[str]:
    """`from fringe.X import name` where X does not define name itself (a re-export: every name has one source)."""
    mods = modules(root)
    defined = {m: defined_names(ast.parse(path.read_text(encoding="utf-8"))) for m, (path, _) in mods.items()}
    return [f"{name}: from {base} import {n}" for name, base, names in imports(root) if base in mods
            for n in names if f"{base}.{n}" not in mods and n not in defined[base]]


def layer_of(module: str) -> int | None:
    """Index in LAYERS, None if no entry names the module."""
    for i, (_, names) in enumerate(LAYERS):
        if module in names:
            return i
    for i, (_, names) in enumerate(LAYERS):
        if any(n.endswith(".*") and (module == n[:-2] or module.startswith(n[:-1])) for n in names):
            return i
    return None


@pytest.fixture(scope="module")
def graph():
    return import_graph()


def test_finds_a_planted_cycle(tmp_path):
    """The parser sees relative, absolute and function-local imports, the cycle they close and a re-export."""
    pkg = tmp_path / "fringe"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .sub import b\n\nx = 1\n")
    (pkg / "sub" / "b.py").write_text("def f():\n    import fringe.c\n")
    (pkg / "c.py").write_text("def g():\n    from . import a\n")
    (pkg / "d.py").write_text("from .a import x\n")
    g = import_graph(tmp_path)
    assert g["fringe.a"] == {"fringe.sub.b"} and g["fringe.d"] == {"fringe.a"}
    assert cycles(g) == [["fringe.a", "fringe.c", "fringe.sub.b"]]
    (pkg / "e.py").write_text("from .a import b, x\n")     # b is a's import of fringe.sub.b
    assert borrowed_names(tmp_path) == ["fringe.e: from fringe.a import b"]


def test_no_import_cycle(graph):
    found = cycles(graph)
    assert not found, "import cycles in model/fringe: " + "; ".join(" <-> ".join(c) for c in found)


def package_of(module: str) -> str:
    """The package a module belongs to: fringe.<sub> for a subpackage's modules, fringe.__main__ with the command
    line's, every other top-level module the base ("fringe")."""
    parts = module.split(".")
    if module == "fringe.__main__":
        return "fringe.cli"
    return ".".join(parts[:2]) if len(parts) > 2 or (len(parts) == 2 and modules()[module][1]) else "fringe"


def test_no_cycle_between_packages(graph):
    """Nor between the packages: no function-local import reaches back into a package that imports this one."""
    packages: dict[str, set[str]] = {}
    for m, targets in graph.items():
        packages.setdefault(package_of(m), set()).update(package_of(t) for t in targets)
    for p, targets in packages.items():
        targets.discard(p)
    found = cycles(packages)
    assert not found, "cycles between fringe's packages: " + "; ".join(" <-> ".join(c) for c in found)


def test_every_module_has_a_layer(graph):
    assert not [m for m in graph if layer_of(m) is None], "place these modules in LAYERS"


def test_imports_go_down(graph):
    upward = [f"{m} ({LAYERS[layer_of(m)][0]}) imports {t} ({LAYERS[layer_of(t)][0]})"
              for m, targets in sorted(graph.items()) for t in sorted(targets)
              if None not in (layer_of(m), layer_of(t)) and layer_of(t) > layer_of(m)]
    assert not upward, "imports against the layer order:\n" + "\n".join(upward)


def test_fixed_is_a_leaf(graph):
    outside = [f"{m} imports {t}" for m, targets in sorted(graph.items()) if m.startswith("fringe.fixed")
               for t in sorted(targets) if not t.startswith("fringe.fixed") and t not in FIXED_MAY_IMPORT]
    assert not outside, "the bit-exact models import outside fringe.fixed:\n" + "\n".join(outside)


def float_twins(root: Path = PACKAGE_ROOT) -> list[str]:
    """Top-level `*_float` functions and `*Float` classes of fringe.fixed: the float twins' names."""
    return [f"{m}.{node.name}" for m, (path, _) in modules(root).items() if m.startswith("fringe.fixed")
            for node in ast.parse(path.read_text(encoding="utf-8")).body
            if (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name.endswith("_float"))
            or (isinstance(node, ast.ClassDef) and node.name.endswith("Float"))]


def test_fixed_holds_bit_exact_models_only(tmp_path):
    """A float twin lives in the float layer (fringe.dsp) beside its users, not next to the model it mirrors; and the
    bit-exact models import nothing above the base layer."""
    assert FIXED_MAY_IMPORT <= set(LAYERS[0][1])
    found = float_twins()
    assert not found, "float twins in fringe.fixed (move them to fringe.dsp):\n" + "\n".join(found)
    (tmp_path / "fringe" / "fixed").mkdir(parents=True)
    (tmp_path / "fringe" / "fixed" / "x.py").write_text("def x_float():\n    pass\n\n\nclass XFloat:\n    pass\n")
    assert float_twins(tmp_path) == ["fringe.fixed.x.x_float", "fringe.fixed.x.XFloat"]


def test_the_loop_imports_down(graph):
    assert sorted(m for m in graph if m.startswith("fringe.loop.")) == sorted(LOOP_ORDER), \
        "place the loop's modules in LOOP_ORDER"
    upward = [f"{m} imports {t}" for m in LOOP_ORDER for t in sorted(graph[m])
              if t in LOOP_ORDER and LOOP_ORDER.index(t) > LOOP_ORDER.index(m)]
    assert not upward, "the loop's modules import against LOOP_ORDER:\n" + "\n".join(upward)


def test_names_come_from_where_they_are_defined():
    borrowed = borrowed_names()
    assert not borrowed, "imported from a module that only imports them itself:\n" + "\n".join(borrowed)


def test_packages_import_nothing_of_fringe(graph):
    """A package's __init__ runs on every import of its modules: it holds no imports of fringe, so that no
    cycle can hide in it."""
    mods = modules()
    assert not [m for m, (_, is_package) in mods.items() if is_package and graph[m]]
