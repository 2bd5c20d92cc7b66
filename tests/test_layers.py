"""The server's packages are layers: every import of ``simx_server`` points down, never up, and no
import circle exists (docs/ARCHITECTURE.md draws them). Imports inside functions and under
``TYPE_CHECKING`` count like the others."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "simx_server"

#: Layer of each package, lowest first: a module may import its own layer and the ones below.
LAYERS = ["base", "sim", "scripts", "scene", "commands", "transport", "zmq", "(top)"]


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else LAYERS.index("(top)")


def imports(path: Path, modules: set[str]) -> set[str]:
    """The ``simx_server`` modules that ``path`` imports (``from pkg import module`` included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [f"{node.module}.{a.name}" for a in node.names]
            names = [n for n in names if n in modules] or [node.module]  # modules of a package, or the module
        else:
            continue
        found |= {n for n in names if n in modules}
    return found - {module_name(path)}


def graph() -> dict[str, set[str]]:
    files = sorted(ROOT.rglob("*.py"))
    modules = {module_name(f) for f in files} - {"simx_server"}
    return {module_name(f): imports(f, modules) for f in files}


def test_every_package_is_a_known_layer():
    packages = {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()} - {"scenes"}
    assert packages <= set(LAYERS), f"packages without a layer: {packages - set(LAYERS)}"


def test_imports_point_down():
    upward = [f"{a} -> {b}" for a, targets in graph().items() for b in sorted(targets) if layer(b) > layer(a)]
    assert not upward, "imports pointing up a layer:\n" + "\n".join(upward)


def test_no_import_circle():
    g = graph()
    state: dict[str, int] = {}  # 1 on the path, 2 done
    path: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        path.append(m)
        for n in sorted(g.get(m, ())):
            if state.get(n) == 1:
                return path[path.index(n):] + [n]
            if n not in state and (cycle := visit(n)):
                return cycle
        path.pop()
        state[m] = 2
        return None

    for m in sorted(g):
        if m not in state and (cycle := visit(m)):
            pytest.fail("import circle: " + " -> ".join(cycle))


def test_the_check_sees_a_violation(tmp_path):
    """The checker itself: an upward import and a circle are found."""
    global ROOT
    saved = ROOT
    try:
        ROOT = tmp_path / "simx_server"
        for pkg, text in {"base": "from simx_server.sim import a\n", "sim": "from simx_server.base import b\n"}.items():
            (ROOT / pkg).mkdir(parents=True)
            (ROOT / pkg / "__init__.py").write_text("")
        (ROOT / "__init__.py").write_text("")
        (ROOT / "base" / "b.py").write_text("from simx_server.sim import a\n")
        (ROOT / "sim" / "a.py").write_text("from simx_server.base import b\n")
        g = graph()
        assert g["simx_server.base.b"] == {"simx_server.sim.a"}
        assert layer("simx_server.sim.a") > layer("simx_server.base.b")
        with pytest.raises(pytest.fail.Exception, match="import circle"):
            test_no_import_circle()
    finally:
        ROOT = saved


def test_no_module_is_long():
    long = {module_name(f): n for f in ROOT.rglob("*.py") if (n := len(f.read_text().splitlines())) > 520}
    assert not long, f"modules over about 500 lines: {long}"
