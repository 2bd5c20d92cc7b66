"""What clients print: ``simxAddStatusbarMessage`` and the ``simxAuxiliaryConsole*`` calls.

A headless server has no status bar and no console windows: their text goes to the server's
log (the ``simx.console`` logger, :data:`simx_server.loop.logs.CONSOLE_LOGGER`), each line prefixed
with the client and the console's title, and cut short (limits.MAX_ERROR_CHARS per line,
limits.MAX_CONSOLE_LINES per print, limits.MAX_CONSOLES open at once). No MuJoCo in here.
"""

from __future__ import annotations

import logging

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.base.arguments import quote
from simx_server.loop import logs
from simx_server.loop.budgets import cut

console_log = logging.getLogger(logs.CONSOLE_LOGGER)  # what clients print (status bar, consoles)

#: Remote commands served by :meth:`Consoles.execute`.
CONSOLE_COMMANDS = ("AddStatusbarMessage", "AuxiliaryConsoleOpen", "AuxiliaryConsoleClose",
                    "AuxiliaryConsolePrint", "AuxiliaryConsoleShow")


class Consoles:
    """The auxiliary consoles clients opened (handle -> title), shared by every client as in V-REP."""

    def __init__(self) -> None:
        self._consoles: dict[int, str] = {}

    def execute(self, name: str, client: str, args: list):
        """Execute one of :data:`CONSOLE_COMMANDS` for ``client``; returns its result.

        Raises:
            ArgumentError: arguments of the wrong type or number.
            UnknownObjectError: no console with that handle.
            RemoteError: too many consoles open.
        """
        return getattr(self, "_" + name)(client, args)

    def _AddStatusbarMessage(self, client: str, args: list) -> None:
        if len(args) != 1 or not isinstance(args[0], str):
            raise P.ArgumentError("simxAddStatusbarMessage takes one string")
        console_log.info("[client %s] %s", client[:8], cut(args[0]))

    def _console(self, args: list) -> int:
        if not args or not isinstance(args[0], int) or args[0] not in self._consoles:
            raise P.UnknownObjectError(f"no auxiliary console with handle {quote(args[0]) if args else None}")
        return args[0]

    def _AuxiliaryConsoleOpen(self, client: str, args: list) -> int:
        if len(args) != 3 or not isinstance(args[0], str):
            raise P.ArgumentError("simxAuxiliaryConsoleOpen takes a title, maxLines and mode")
        if len(self._consoles) >= limits.MAX_CONSOLES:
            raise P.RemoteError(f"too many auxiliary consoles open: at most {limits.MAX_CONSOLES} "
                                "(limits.MAX_CONSOLES); close some")
        handle = max(self._consoles, default=0) + 1
        self._consoles[handle] = title = cut(args[0], 200)
        console_log.info("[client %s] console %d %s opened", client[:8], handle, quote(title))
        return handle

    def _AuxiliaryConsoleClose(self, client: str, args: list) -> None:
        console_log.info("[client %s] console %s closed", client[:8], quote(self._consoles.pop(self._console(args))))

    def _AuxiliaryConsolePrint(self, client: str, args: list) -> None:
        title = self._consoles[self._console(args)]
        text = args[1] if len(args) == 2 else None
        if text is not None and not isinstance(text, str):
            raise P.ArgumentError("console text must be a string or None")
        lines = (text or "").splitlines() or [""]
        for line in lines[:limits.MAX_CONSOLE_LINES]:
            console_log.info("[client %s] [%s] %s", client[:8], title, cut(line) if text is not None else "(cleared)")
        if len(lines) > limits.MAX_CONSOLE_LINES:
            console_log.info("[client %s] [%s] (%d more lines not shown)", client[:8], title,
                             len(lines) - limits.MAX_CONSOLE_LINES)

    def _AuxiliaryConsoleShow(self, client: str, args: list) -> None:
        self._console(args)
