"""Public docstrings carry their sections (issue 30): every public function and method of
``simx_server/sim/*.py``, ``simx_server/scripts/facade*.py`` and ``simx_client/*.py`` that takes
arguments has an ``Args:`` section, and one that returns a value has ``Returns:`` (or
``Yields:``). Read from the source with :mod:`ast`, nothing imported.

Exempt: names starting with ``_``, ``@overload`` stubs, property setters, properties (their
docstring is the value's), methods of private classes, and the client's legacy ``simx*``
functions (``simxGetObjectHandle``...), which keep ``vrep.py``'s own one-line style.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GLOBS = ("simx_server/sim/*.py", "simx_server/scripts/facade*.py", "simx_client/*.py")
LEGACY_CLIENT = re.compile(r"simx[A-Z]\w*$")  # vrep.py's remote API functions

Function = ast.FunctionDef | ast.AsyncFunctionDef


def _returns_value(fn: Function) -> bool:
    if fn.returns is not None:
        return ast.unparse(fn.returns) not in ("None", "NoReturn")
    return any(isinstance(n, ast.Return) and n.value is not None
               and not (isinstance(n.value, ast.Constant) and n.value.value is None) for n in ast.walk(fn))


def _parameters(fn: Function) -> list[str]:
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    names += [f"*{a.vararg.arg}"] if a.vararg else []
    names += [f"**{a.kwarg.arg}"] if a.kwarg else []
    return [n for n in names if n not in ("self", "cls")]


def _decorators(fn: Function) -> set[str]:
    return {d.id if isinstance(d, ast.Name) else d.attr for d in fn.decorator_list
            if isinstance(d, (ast.Name, ast.Attribute))}


def _public(tree: ast.Module):
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node.name, node
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for sub in node.body:
                if isinstance(sub, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield f"{node.name}.{sub.name}", sub


def missing_sections(source: str, label: str, exempt: re.Pattern | None = None) -> list[str]:
    """``label:line name: needs Args/Returns`` for each public function of ``source`` whose
    docstring lacks a section it needs (see the module's text)."""
    found = []
    for name, fn in _public(ast.parse(source)):
        decorators = _decorators(fn)
        if fn.name.startswith("_") or "overload" in decorators or "setter" in decorators:
            continue
        if exempt is not None and exempt.match(fn.name):
            continue
        doc = ast.get_docstring(fn) or ""
        need = []
        if _parameters(fn) and "Args:" not in doc:
            need.append("Args")
        if (_returns_value(fn) and not decorators & {"property", "cached_property"}
                and "Returns:" not in doc and "Yields:" not in doc):
            need.append("Returns")
        if need:
            found.append(f"{label}:{fn.lineno} {name}: needs {'/'.join(need)}")
    return found


def test_public_functions_have_their_sections():
    files = sorted(f for pattern in GLOBS for f in REPO.glob(pattern))
    assert len(files) > 50, f"the globs found only {len(files)} files: {GLOBS}"
    found = [m for f in files for m in missing_sections(
        f.read_text(encoding="utf-8"), str(f.relative_to(REPO)),
        LEGACY_CLIENT if f.parent.name == "simx_client" else None)]
    assert not found, "public docstrings without their sections (issue 30):\n" + "\n".join(found)


def test_the_check_finds_what_is_missing():
    source = '''
def bare(a):
    """No sections."""
    return a

def documented(a):
    """Fine.

    Args:
        a: a number, m.

    Returns:
        The same, m.
    """
    return a

def no_value(a) -> None:
    """Args only needed.

    Args:
        a: anything.
    """

class Thing:
    def method(self, x):
        """Args:
            x: anything.
        """
        return x

    @property
    def size(self) -> float:
        """m."""
        return 1.0

    def _private(self, y):
        return y

class _Hidden:
    def method(self, z):
        return z

def simxGetPing(clientID):
    return 0
'''
    def names(found: list[str]) -> list[str]:
        return [m.split(" ", 1)[1] for m in found]

    assert names(missing_sections(source, "f.py")) == [
        "bare: needs Args/Returns",
        "Thing.method: needs Returns",
        "simxGetPing: needs Args/Returns",
    ]
    assert names(missing_sections(source, "f.py", LEGACY_CLIENT)) == [
        "bare: needs Args/Returns",
        "Thing.method: needs Returns",
    ]
    assert missing_sections(source, "f.py")[0].startswith("f.py:2 ")
