"""The one table of CoppeliaSim's API: every ``sim.NAME``, ``simIK.NAME``, ``simOMPL.NAME`` and
``simVision.NAME`` simx serves, found by name.

Each function is a plain module-level function of :mod:`simx_server.api.sim` (or
:mod:`simx_server.api.simik`), registered once under its CoppeliaSim name with
:func:`sim_function` (:func:`simik_function`); it takes a
:class:`~simx_server.api.context.CallContext` (the world, the caller, its stores) and then
CoppeliaSim's arguments. Lua child scripts, Python child scripts and ZMQ clients all call through
this table (as CoppeliaSim's own ``luaScriptFunctions.cpp`` and Gymnasium's registry: one name,
one definition); docs/COVERAGE.md and docs/SCRIPTS.md are generated from it.

Registering a name twice raises :class:`DuplicateApiNameError` when the second module is imported.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


class DuplicateApiNameError(RuntimeError):
    """A CoppeliaSim name registered by two functions (a programming error, raised at import)."""


class Callers(enum.Flag):
    """Who may call a function: child scripts (Lua and Python), remote API clients (ZMQ), or both."""

    SCRIPTS = enum.auto()
    CLIENTS = enum.auto()
    ALL = SCRIPTS | CLIENTS


@dataclasses.dataclass(frozen=True)
class ApiFunction:
    """One entry of the table.

    Attributes:
        library: ``"sim"``, ``"simIK"``, ``"simOMPL"`` or ``"simVision"``.
        name: CoppeliaSim's name (without the library prefix).
        function: the implementation, ``function(ctx, *args)``.
        callers: who may call it (the others get an UnsupportedError naming the restriction).
    """

    library: str
    name: str
    function: Callable[..., Any]
    callers: Callers = Callers.ALL

    @property
    def module(self) -> str:
        """The module that defines it (its category)."""
        return self.function.__module__

    @property
    def qualified(self) -> str:
        """``sim.NAME`` / ``simIK.NAME``."""
        return f"{self.library}.{self.name}"


class ApiTable:
    """Name -> :class:`ApiFunction` of one library (``sim`` or ``simIK``).

    Args:
        library: the library's name as programs write it.
    """

    def __init__(self, library: str):
        self.library = library
        self._entries: dict[str, ApiFunction] = {}
        #: ``NAME -> value`` of the library's constants (``sim.handle_world``...), filled by its package.
        self.constants: dict[str, Any] = {}

    def register(self, name: str, function: Callable[..., Any], callers: Callers = Callers.ALL) -> None:
        """Add ``name``; DuplicateApiNameError if it is already in the table."""
        old = self._entries.get(name)
        if old is not None:
            raise DuplicateApiNameError(
                f"{self.library}.{name} is registered twice: by {old.module}.{old.function.__name__} "
                f"and {function.__module__}.{function.__name__}"
            )
        self._entries[name] = ApiFunction(self.library, name, function, callers)

    def get(self, name: str) -> ApiFunction | None:
        """The entry of ``name``, or None."""
        return self._entries.get(name)

    def __getitem__(self, name: str) -> ApiFunction:
        return self._entries[name]

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def names(self, callers: Callers = Callers.ALL) -> tuple[str, ...]:
        """Sorted names of the entries that any of ``callers`` may call."""
        return tuple(sorted(n for n, e in self._entries.items() if e.callers & callers))

    def entries(self) -> list[ApiFunction]:
        """Every entry, sorted by name."""
        return [self._entries[n] for n in sorted(self._entries)]


#: ``sim.NAME`` of CoppeliaSim 4.x (and the V-REP 3.x names scripts still call through ``sim``).
SIM = ApiTable("sim")
#: ``simIK.NAME`` of CoppeliaSim 4.x.
SIMIK = ApiTable("simIK")
#: ``simOMPL.NAME`` of CoppeliaSim 4.x's OMPL plug-in (:mod:`simx_server.api.simompl`).
SIMOMPL = ApiTable("simOMPL")
#: ``simVision.NAME`` of CoppeliaSim 4.x's vision plug-in (:mod:`simx_server.api.simvision`).
SIMVISION = ApiTable("simVision")


def _decorator(table: ApiTable, names: tuple[str, ...], callers: Callers) -> Callable[[F], F]:
    def register(function: F) -> F:
        for name in names or (function.__name__,):
            table.register(name, function, callers)
        return function

    return register


def sim_function(*names: str, callers: Callers = Callers.ALL) -> Callable[[F], F]:
    """Register the decorated function as ``sim.NAME`` for each of ``names`` (default: its own name).

    Args:
        names: CoppeliaSim names (a function that CoppeliaSim knows under two names lists both).
        callers: who may call it (default both child scripts and remote clients).

    Raises:
        DuplicateApiNameError: a name is already registered (at import).
    """
    return _decorator(SIM, names, callers)


def simik_function(*names: str, callers: Callers = Callers.ALL) -> Callable[[F], F]:
    """Register the decorated function as ``simIK.NAME`` (as :func:`sim_function`)."""
    return _decorator(SIMIK, names, callers)


def simompl_function(*names: str, callers: Callers = Callers.ALL) -> Callable[[F], F]:
    """Register the decorated function as ``simOMPL.NAME`` (as :func:`sim_function`)."""
    return _decorator(SIMOMPL, names, callers)


def simvision_function(*names: str, callers: Callers = Callers.ALL) -> Callable[[F], F]:
    """Register the decorated function as ``simVision.NAME`` (as :func:`sim_function`)."""
    return _decorator(SIMVISION, names, callers)
