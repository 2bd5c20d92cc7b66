"""Script text as Lua and CoppeliaSim read it: the first line ``loadfile`` skips, and the
version-gated rewrites CoppeliaSim applies to scripts of older files when it loads them.

:func:`lua_file_text` does what Lua's ``loadfile`` does before parsing (a UTF-8 byte-order mark
and a first line starting with ``#`` are skipped; the line is kept empty so that line numbers
stay those of the file). :func:`rewrite` applies CoppeliaSim's text rewrites for a script written
by V-REP / CoppeliaSim ``version`` (e.g. 30600 for 3.6.0; the ``vrep_version=`` setting of the
script's object): each entry of :data:`REWRITES` is one of CoppeliaSim's load-time steps
(``CDetachedScript::_adjustScriptTextN_old``) that changes what a script does in simx. The steps
that only rename functions are not text rewrites here: both names resolve to one ``sim`` function
(:mod:`simx_server.api.legacy_names`). docs/SCRIPTS.md lists each rewrite.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["REWRITES", "Rewrite", "lua_file_text", "rewrite"]


def lua_file_text(raw: bytes) -> bytes:
    """The Lua text of a script file as ``loadfile`` reads it: without a UTF-8 BOM, and with a
    first line that starts with ``#`` emptied (its newline kept, so line numbers do not move)."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    if raw.startswith(b"#"):
        end = raw.find(b"\n")
        raw = b"" if end < 0 else raw[end:]
    return raw


@dataclass(frozen=True)
class Rewrite:
    """One of CoppeliaSim's load-time rewrites: applies to scripts written by a version below
    ``below`` (exclusive); ``pattern`` (a regular expression on the text) becomes ``replacement``."""

    step: str
    below: int
    pattern: str
    replacement: str
    why: str


# The abouttostop test in both spellings (3.x globals, 4.x sim table), with or without spaces.
_STATE = r"(?:sim\.getSimulationState|simGetSimulationState)\(\)\s*~=\s*(?:sim\.|sim_)simulation_advancing_abouttostop"

#: CoppeliaSim's rewrites that change behaviour, in its order.
REWRITES: tuple[Rewrite, ...] = (
    Rewrite("_adjustScriptText13_old", 40200, _STATE, "true",
            "4.2 runs threads as coroutines that are simply not resumed after the simulation stops: "
            "a loop `while sim.getSimulationState()~=sim.simulation_advancing_abouttostop do` becomes "
            "`while true do`"),
)


def rewrite(text: bytes, version: int | None) -> tuple[bytes, list[str]]:
    """``text`` after CoppeliaSim's rewrites for a script written by ``version`` (None: a script
    written for CoppeliaSim 4.x as it is now, nothing rewritten); returns the text and the steps
    that changed it."""
    if version is None:
        return text, []
    done = []
    for step in REWRITES:
        if version < step.below:
            new = re.sub(step.pattern.encode(), step.replacement.encode(), text)
            if new != text:
                done.append(step.step)
                text = new
    return text, done
