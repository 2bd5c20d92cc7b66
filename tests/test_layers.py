"""The server's packages are layers: every import of ``simx_server`` points down, never up, and no
import circle exists (docs/ARCHITECTURE.md draws them). Server and client share only the wire
package ``simx_wire``, which imports neither; the client reaches the server side in one module
(``simx_client/servers.py``); the benchmarks have no import circle. Imports inside functions and
under ``TYPE_CHECKING`` count like the others."""

from __future__ import annotations

import ast
import functools
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROOT = REPO / "simx_server"

#: Layer of each package, lowest first: a module may import its own layer and the ones below.
LAYERS = ["base", "sim", "api", "scripts", "scene", "commands", "loop", "legacy", "zmq", "(top)"]


def nodes(path: Path) -> tuple[ast.AST, ...]:
    """Every node of the module at ``path`` (``ast.walk`` of its parse), parsed once per version
    of the file: most checks here walk every module of the tree (0.5 s of CPU each)."""
    stat = path.stat()
    return _nodes(path, stat.st_mtime_ns, stat.st_size)


@functools.cache
def _nodes(path: Path, _mtime: int, _size: int) -> tuple[ast.AST, ...]:
    return tuple(ast.walk(ast.parse(path.read_text(), str(path))))


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else LAYERS.index("(top)")


def imports(path: Path, modules: set[str]) -> set[str]:
    """The ``simx_server`` modules that ``path`` imports (``from pkg import module`` included)."""
    found = set()
    for node in nodes(path):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [f"{node.module}.{a.name}" for a in node.names]
            names = [n for n in names if n in modules] or [node.module]  # modules of a package, or the module
        else:
            continue
        found |= {n for n in names if n in modules}
    return found - {module_name(path)}


def graph(root: Path | None = None) -> dict[str, set[str]]:
    """Module -> the modules of its own package it imports, for ``simx_server`` (or ``root``)."""
    return {m: set(targets) for m, targets in _graph(root or ROOT).items()}  # a copy: callers may change it


@functools.cache
def _graph(root: Path) -> dict[str, frozenset[str]]:
    """:func:`graph`, parsed once per folder (1.5 s of CPU for simx_server; five tests ask)."""
    files = sorted(root.rglob("*.py"))
    modules = {module_name(f) for f in files} - {root.name}
    return {module_name(f): frozenset(imports(f, modules)) for f in files}


def imported_packages(path: Path) -> dict[str, int]:
    """Top-level package -> first line, of every absolute import in ``path``."""
    found: dict[str, int] = {}
    for node in nodes(path):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for n in names:
            found.setdefault(n.split(".")[0], node.lineno)
    return found


def imports_of(package: str, forbidden: set[str], allowed: frozenset[str] = frozenset()) -> list[str]:
    """``file:line -> package`` for each import of a ``forbidden`` package in ``package``'s files
    (files in ``allowed``, relative to the repository, excepted)."""
    return [f"{f.relative_to(REPO)}:{line} -> {name}" for f in sorted((REPO / package).rglob("*.py"))
            if str(f.relative_to(REPO)) not in allowed
            for name, line in imported_packages(f).items() if name in forbidden]


def test_every_package_is_a_known_layer():
    packages = {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()} - {"scenes"}
    assert packages <= set(LAYERS), f"packages without a layer: {packages - set(LAYERS)}"


def test_imports_point_down():
    upward = [f"{a} -> {b}" for a, targets in graph().items() for b in sorted(targets) if layer(b) > layer(a)]
    assert not upward, "imports pointing up a layer:\n" + "\n".join(upward)


def test_no_import_circle(root: Path | None = None):
    g = graph(root)
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


def test_the_server_does_not_import_the_client():
    found = imports_of("simx_server", {"simx_client"})
    assert not found, ("simx_server imports the client package (the wire schema is simx_wire; "
                       "scripts/wire_imports.py rewrites such imports):\n" + "\n".join(found))


def test_the_wire_package_imports_neither_side():
    found = imports_of("simx_wire", {"simx_server", "simx_client", "simx_viewer"})
    assert not found, "simx_wire imports a side:\n" + "\n".join(found)


def test_the_client_starts_servers_in_one_place():
    found = imports_of("simx_client", {"simx_server"}, allowed=frozenset({"simx_client/servers.py"}))
    assert not found, "simx_client imports simx_server outside simx_client/servers.py:\n" + "\n".join(found)


def test_pyrep_is_a_client_of_the_api_table():
    """``pyrep`` sits on top: the server, the wire and the client never import it, and it reaches
    the server only through the API table, the simulation and the run state (docs/PYREP.md)."""
    for package in ("simx_server", "simx_wire", "simx_client", "simx_viewer"):
        found = imports_of(package, {"pyrep"})
        assert not found, f"{package} imports pyrep:\n" + "\n".join(found)
    allowed = {"simx_server", "simx_server.api", "simx_server.scene.simulation", "simx_server.sim.state"}
    used = set()
    for f in sorted((REPO / "pyrep").rglob("*.py")):
        for node in nodes(f):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("simx_server"):
                used.add(node.module)
    assert used <= allowed, f"pyrep imports server modules beyond the table: {sorted(used - allowed)}"
    test_no_import_circle(REPO / "pyrep")


def test_no_import_circle_in_the_benchmarks():
    test_no_import_circle(REPO / "benchmarks")


def test_the_package_checks_see_a_violation(tmp_path, monkeypatch):
    """The checker itself: a server module importing the client, and a lazy import in a function."""
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    (tmp_path / "simx_server").mkdir()
    (tmp_path / "simx_server" / "a.py").write_text("def f():\n    from simx_client.protocol import X\n")
    (tmp_path / "simx_wire").mkdir()
    (tmp_path / "simx_wire" / "b.py").write_text("import os\nimport simx_server.pool\n")
    assert imports_of("simx_server", {"simx_client"}) == ["simx_server/a.py:2 -> simx_client"]
    assert imports_of("simx_wire", {"simx_server"}) == ["simx_wire/b.py:2 -> simx_server"]
    assert imports_of("simx_wire", {"simx_server"}, allowed=frozenset({"simx_wire/b.py"})) == []


def test_no_module_is_long():
    """Every module of the project's packages stays within 520 lines; a generated table (its
    docstring says GENERATED, and the script that writes it) is data, not a module to read."""
    packages = ("simx_server", "simx_client", "simx_wire", "simx_viewer", "pyrep")
    files = [f for top in packages for f in (REPO / top).rglob("*.py")]
    long = {str(f.relative_to(REPO)): n for f in files if (n := len((text := f.read_text()).splitlines())) > 520
            and "(GENERATED: do not edit)" not in text[:200]}
    assert not long, f"modules over about 500 lines: {long}"


def test_the_loop_imports_no_front_door():
    """The simulation loop (``simx_server.loop``) serves its front doors through
    ``loop.front_door``'s interface: it imports neither the legacy door nor the ZMQ one."""
    doors = ("simx_server.legacy", "simx_server.zmq")
    found = [f"{a} -> {b}" for a, targets in graph().items() if a.startswith("simx_server.loop")
             for b in sorted(targets) if b.startswith(doors)]
    assert not found, "the loop imports a front door:\n" + "\n".join(found)
    assert layer("simx_server.loop.core") < min(layer("simx_server.legacy.server"), layer("simx_server.zmq.service"))


def test_the_front_doors_do_not_import_each_other():
    """What both front doors need lives below them (``loop``, ``commands``), not in one of them."""
    found = [f"{a} -> {b}" for a, targets in graph().items() for b in sorted(targets)
             if (a.startswith("simx_server.zmq") and b.startswith("simx_server.legacy"))
             or (a.startswith("simx_server.legacy") and b.startswith("simx_server.zmq"))]
    assert not found, "a front door imports the other:\n" + "\n".join(found)


def registry_imports(package: str) -> list[str]:
    """``file:line -> name`` for each import of the legacy command registry in ``package``'s
    files: ``simx_server.commands`` itself (its ``HANDLERS`` table, by command name) or a
    ``HANDLERS`` name from anywhere. Functions of ``simx_server.commands.<module>`` imported by
    their own names are no registry."""
    found = []
    for f in sorted((REPO / package).rglob("*.py")):
        for node in nodes(f):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names if a.name == "simx_server.commands"]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [f"{node.module}.{a.name}" for a in node.names
                         if node.module == "simx_server.commands" or a.name == "HANDLERS"]
            else:
                continue
            found += [f"{f.relative_to(REPO)}:{node.lineno} -> {n}" for n in names]
    return found


def test_the_zmq_door_calls_no_legacy_handler_by_name():
    """The ZMQ front door calls what it shares with the legacy one (parameters, passive images
    ...) by the function's own name, in the layer that owns it, never a legacy command's handler
    looked up in ``HANDLERS``."""
    found = registry_imports("simx_server/zmq")
    assert not found, "simx_server/zmq imports the legacy command registry:\n" + "\n".join(found)


def test_the_registry_check_sees_a_violation(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    door = tmp_path / "simx_server" / "zmq"
    door.mkdir(parents=True)
    (door / "a.py").write_text("from simx_server.commands.sensors import image_pixels\n"
                               "def f():\n    from simx_server.commands import HANDLERS\n")
    (door / "b.py").write_text("import simx_server.commands\nfrom simx_server.legacy.x import HANDLERS\n")
    assert registry_imports("simx_server/zmq") == [
        "simx_server/zmq/a.py:3 -> simx_server.commands.HANDLERS",
        "simx_server/zmq/b.py:1 -> simx_server.commands",
        "simx_server/zmq/b.py:2 -> simx_server.legacy.x.HANDLERS"]


def test_no_front_door_subclasses_the_loop():
    """A front door is attached to the loop (``loop.attach(door)``) and reaches it through
    ``loop.front_door``'s interface; none extends :class:`simx_server.loop.core.Loop` to override
    its policies (pacing, stepping, the barrier, expiry)."""
    found = []
    for path in ROOT.rglob("*.py"):
        for node in nodes(path):
            if isinstance(node, ast.ClassDef):
                bases = {b.id if isinstance(b, ast.Name) else b.attr if isinstance(b, ast.Attribute) else ""
                         for b in node.bases}
                if "Loop" in bases:
                    found.append(f"{module_name(path)}.{node.name}")
    assert not found, "classes that subclass the loop: " + ", ".join(found)


def test_the_subclass_check_sees_one(tmp_path, monkeypatch):
    (tmp_path / "simx_server" / "legacy").mkdir(parents=True)
    (tmp_path / "simx_server" / "legacy" / "door.py").write_text(
        "from simx_server.loop import core\n\nclass Door(core.Loop):\n    pass\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path / "simx_server")
    with pytest.raises(AssertionError, match="simx_server.legacy.door.Door"):
        test_no_front_door_subclasses_the_loop()


def test_no_class_has_more_than_three_bases():
    """No class of the server is assembled from many mixins (the ``sim`` API once was one class
    of 32 mixin bases, whose shadowed names went unnoticed): at most 3 bases each."""
    wide = [f"{f.relative_to(REPO)}:{n.lineno} {n.name} ({len(n.bases)} bases)"
            for f in sorted(ROOT.rglob("*.py")) for n in nodes(f)
            if isinstance(n, ast.ClassDef) and len(n.bases) > 3]
    assert not wide, wide


def test_every_api_name_is_registered_once_by_one_decorator():
    """Each ``@sim_function``/``@simik_function`` name appears once in the source of the API
    package (the table also refuses a second registration at import), and the table holds them."""
    from simx_server.api import SIM, SIMIK

    seen: dict[tuple[str, str], list[str]] = {}
    for f in sorted((ROOT / "api").rglob("*.py")):
        for node in nodes(f):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("sim_function", "simik_function")):
                for arg in node.args:
                    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                        seen.setdefault((node.func.id, arg.value), []).append(f"{f.name}:{node.lineno}")
    twice = {k: v for k, v in seen.items() if len(v) > 1}
    assert not twice, twice
    literal = {name for (kind, name) in seen if kind == "sim_function"}
    assert literal <= set(SIM) and {n for (k, n) in seen if k == "simik_function"} <= set(SIMIK)
    assert len(literal) > 400
