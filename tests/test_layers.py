"""The package's layers (DEVELOPERS.md, "Layers"): imports go downwards only, features never import
each other, no import cycles, no library imports hidden inside functions, no module over 400 lines.

The check reads the source with ``ast``; it does not import the package, so a cycle cannot hide
behind an import order that happens to work.
"""
import ast
import re
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "ecostudy"

# rank of every layer; features share a rank and may not import each other
LAYERS = {"core": 0, "io": 1, "ocp": 2, "analysis": 3, "das": 4, "heuristics": 4, "network": 4, "control": 4,
          "heavyhaul": 4, "calibration": 4,
          "studies": 5, "report": 6, "api": 7, "cli": 8}
FEATURES = {"das", "heuristics", "network", "control", "heavyhaul", "calibration"}
# optional or heavy dependencies a function may import when it needs them
LAZY_OK = ("matplotlib", "dask", "distributed", "rich", "ecostudy.report.plots", "ecostudy.report.netplots",
           "pyomo.environ")  # Pyomo's plugins (solvers, MindtPy): the DAS mode choice's search only
# the command line imports the library inside each command, so that `ecostudy --help` and option
# errors answer at once (0.3 s instead of 3 s with Pyomo, scipy and pandas loaded)
LAZY_LAYERS = {"cli"}
MAX_LINES = 400


def modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        name = ".".join(("ecostudy",) + tuple(p for p in parts if p != "__init__"))
        yield name, path


def layer(name):
    parts = name.split(".")
    if len(parts) < 2 or parts[1] not in LAYERS:
        return None  # ecostudy itself, __main__
    return parts[1]


def imports(path, name):
    """(imported name, line, inside a function) for every import of a module; ``from a.b import c``
    gives ``a.b.c`` (:func:`resolve` finds the module). Relative imports are resolved too."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []

    def visit(node, nested):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                out.extend((a.name, child.lineno, nested) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:  # from .x import y, from .. import z
                    parts = package.split(".")[:len(package.split(".")) - child.level + 1]
                    base = ".".join(parts + ([base] if base else []))
                out.extend((f"{base}.{a.name}", child.lineno, nested) for a in child.names)
            visit(child, nested or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))

    visit(ast.parse(path.read_text()), False)
    return out


def resolve(target, known):
    """The ecostudy module an import names (``ecostudy.ocp.space.KN`` -> ``ecostudy.ocp.space``)."""
    while target and target not in known:
        target = target.rsplit(".", 1)[0] if "." in target else ""
    return target


def graph():
    known = dict(modules())
    edges, lazy = {}, []
    for name, path in known.items():
        edges[name] = set()
        for target, line, nested in imports(path, name):
            if nested and not target.startswith(LAZY_OK) and layer(name) not in LAZY_LAYERS:
                lazy.append(f"{path.relative_to(PACKAGE.parent)}:{line} imports {target} inside a function")
            if target.startswith("ecostudy"):
                mod = resolve(target, known)
                if mod and mod != name and mod != "ecostudy" and not (nested and target.startswith(LAZY_OK)):
                    edges[name].add(mod)
    return known, edges, lazy


def test_no_import_cycles():
    _, edges, _ = graph()
    state, cycles = {}, []

    def dfs(node, stack):
        state[node] = 1
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                dfs(nxt, stack + [nxt])
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            dfs(node, [node])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_imports_go_downwards_and_features_stay_apart():
    _, edges, _ = graph()
    wrong = []
    for src, targets in edges.items():
        a = layer(src)
        for dst in targets:
            b = layer(dst)
            if a is None or b is None or a == b:
                continue
            if LAYERS[b] > LAYERS[a] or (LAYERS[b] == LAYERS[a] and {a, b} <= FEATURES):
                wrong.append(f"{src} ({a}) imports {dst} ({b})")
            if LAYERS[b] == LAYERS[a] and a != b and not {a, b} <= FEATURES:
                wrong.append(f"{src} ({a}) imports {dst} ({b}) of the same rank")
    assert not wrong, "imports against the layers:\n" + "\n".join(sorted(wrong))


def test_no_library_imports_inside_functions():
    _, _, lazy = graph()
    assert not lazy, "\n".join(lazy)


def test_every_module_is_in_a_layer_and_short():
    long = [f"{p.relative_to(PACKAGE.parent)}: {n} lines" for _, p in modules()
            if (n := len(p.read_text().splitlines())) > MAX_LINES]
    stray = [name for name, p in modules() if layer(name) is None and p.name not in ("__init__.py", "__main__.py")]
    assert not long, "modules over 400 lines:\n" + "\n".join(long)
    assert not stray, f"modules outside the layers: {stray}"


def test_the_command_line_is_thin():
    """The command line parses, calls ``ecostudy.api`` and prints: all of ``cli/`` under 400 lines."""
    sizes = {p.name: len(p.read_text().splitlines()) for p in sorted((PACKAGE / "cli").glob("*.py"))}
    assert sum(sizes.values()) < MAX_LINES, f"ecostudy/cli: {sum(sizes.values())} lines ({sizes}); move logic to the API"


def test_the_check_sees_a_cycle_and_an_upward_import(tmp_path, monkeypatch):
    """The checks above can fail: core.errors importing the cli is both an upward import and
    (cli.app imports core.errors) a cycle."""
    fake = tmp_path / "ecostudy"
    for name, path in modules():
        target = fake / path.relative_to(PACKAGE)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(path.read_text())
    (fake / "core" / "errors.py").write_text((fake / "core" / "errors.py").read_text()
                                            + "\nfrom ecostudy.cli.app import app\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", fake)
    _, edges, _ = graph()
    assert "ecostudy.cli.app" in edges["ecostudy.core.errors"]
    for check, message in ((test_imports_go_downwards_and_features_stay_apart,
                            "ecostudy.core.errors (core) imports ecostudy.cli.app (cli)"),
                           (test_no_import_cycles, "ecostudy.core.errors -> ecostudy.cli.app")):
        with pytest.raises(AssertionError, match=re.escape(message)):
            check()
