"""CoppeliaSim 4.x's window functions (``sim.auxiliaryConsoleOpen``, ``sim.floatingViewAdd``,
``sim.textEditorOpen`` ...), answered as a headless CoppeliaSim answers them.

simx has no window: text meant for a console or an editor goes to the server's log (one INFO
line naming the caller), the rest answer neutral values (a handle for what was opened, page 0,
navigation mode 0, an empty editor) instead of errors, so that a 4.x program that opens an
auxiliary console or a floating view runs on. Nothing is drawn. docs/COVERAGE.md lists them as
"headless".
"""

from __future__ import annotations

import logging
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base.arguments import as_integer as _int, as_text as _text
from simx_wire.protocol import ArgumentError

log = logging.getLogger("simx.scripts")

_MAX_LOGGED = 1000  # characters of one console line in the log


def _line(text: str) -> str:
    text = text if len(text) <= _MAX_LOGGED else text[:_MAX_LOGGED] + f"... ({len(text)} characters)"
    return text.encode("unicode_escape").decode("ascii")  # one log line whatever the text holds


# Auxiliary consoles, text editors, floating views, pages, navigation, dialogs, selection.

def _gui_handle(ctx: CallContext) -> int:
    n = ctx.state.gui_handles + 1
    ctx.state.gui_handles = n
    return n


@sim_function("auxiliaryConsoleOpen")
def auxiliaryConsoleOpen(ctx: CallContext, title: Any, maxLines: Any, mode: Any, position: Any = None,  # noqa: N802, N803
                         size: Any = None, textColor: Any = None, backgroundColor: Any = None) -> int:  # noqa: N803
    """A console handle (from 1); its text goes to the server log, prefixed by ``title``.

    ``sim.auxiliaryConsoleOpen``.

    Args:
        title: the console's title (first 100 characters kept).
        maxLines: ignored (headless).
        mode: ignored.
        position: ignored (pixels).
        size: ignored (pixels).
        textColor: ignored.
        backgroundColor: ignored.

    Returns:
        The console handle.

    Raises:
        ArgumentError: ``title`` is not a string.
    """
    h = _gui_handle(ctx)
    consoles = ctx.state.consoles or {}
    consoles[h] = _text(title, "title")[:100]
    ctx.state.consoles = consoles
    return h


@sim_function("auxiliaryConsolePrint")
def auxiliaryConsolePrint(ctx: CallContext, consoleHandle: Any, text: Any) -> int:  # noqa: N802, N803
    """Write ``text`` to the server log (INFO, ``[label: title]``); 1 (0 for an unknown console).

    ``sim.auxiliaryConsolePrint``.

    Args:
        consoleHandle: from :func:`auxiliaryConsoleOpen`.
        text: the text, or None (clears the console: nothing logged).

    Returns:
        1, or 0 for an unknown console.

    Raises:
        ArgumentError: ``consoleHandle`` not an integer, or ``text`` not a string.
    """
    title = (ctx.state.consoles or {}).get(_int(consoleHandle, "consoleHandle"))
    if title is None:
        return 0
    if text is not None:  # nil clears the console: nothing to log
        log.info("[%s: %s] %s", ctx.label, title, _line(_text(text, "text")))
    return 1


@sim_function("auxiliaryConsoleClose")
def auxiliaryConsoleClose(ctx: CallContext, consoleHandle: Any) -> int:  # noqa: N802, N803
    """``sim.auxiliaryConsoleClose``: forget the console.

    Args:
        consoleHandle: from :func:`auxiliaryConsoleOpen`.

    Returns:
        1, or 0 for an unknown console.

    Raises:
        ArgumentError: ``consoleHandle`` is not an integer.

    """
    return int((ctx.state.consoles or {}).pop(_int(consoleHandle, "consoleHandle"), None) is not None)


@sim_function("auxiliaryConsoleShow")
def auxiliaryConsoleShow(ctx: CallContext, consoleHandle: Any, showState: Any) -> int:  # noqa: N802, N803
    """``sim.auxiliaryConsoleShow``: nothing to show (headless).

    Args:
        consoleHandle: from :func:`auxiliaryConsoleOpen`.
        showState: ignored.

    Returns:
        1 for an open console, else 0.

    Raises:
        ArgumentError: ``consoleHandle`` is not an integer.

    """
    return int(_int(consoleHandle, "consoleHandle") in (ctx.state.consoles or {}))


@sim_function("textEditorOpen")
def textEditorOpen(ctx: CallContext, initText: Any, properties: Any = "") -> int:  # noqa: N802, N803
    """A handle; no editor opens (headless).

    ``sim.textEditorOpen``.

    Args:
        initText: ignored.
        properties: ignored.

    Returns:
        The editor's handle.
    """
    return _gui_handle(ctx)


@sim_function("textEditorClose")
def textEditorClose(ctx: CallContext, handle: Any) -> tuple[str, list[int], list[int]]:  # noqa: N802
    """``sim.textEditorClose`` of an editor nobody saw.

    Args:
        handle: the editor's handle (not checked).

    Returns:
        ``("", [0, 0], [0, 0])``: text, position and size (pixels).

    """
    return "", [0, 0], [0, 0]


@sim_function("textEditorShow")
def textEditorShow(ctx: CallContext, handle: Any, showState: Any) -> None:  # noqa: N802, N803
    """``sim.textEditorShow``: nothing to show (headless).

    Args:
        handle: the editor's handle.
        showState: ignored.

    Raises:
        ArgumentError: ``handle`` is not an integer.

    """
    _int(handle, "handle")


@sim_function("textEditorGetInfo")
def textEditorGetInfo(ctx: CallContext, handle: Any) -> tuple[str, list[int], list[int], bool]:  # noqa: N802
    """``text, pos, size, visible`` of an editor nobody sees: empty, at 0, hidden.

    Args:
        handle: the editor's handle (not checked).

    Returns:
        ``("", [0, 0], [0, 0], False)``.
    """
    return "", [0, 0], [0, 0], False


@sim_function("floatingViewAdd")
def floatingViewAdd(ctx: CallContext, posX: Any, posY: Any, sizeX: Any, sizeY: Any, options: Any) -> int:  # noqa: N802, N803
    """A view handle; no view opens (headless).

    ``sim.floatingViewAdd``.

    Args:
        posX: ignored (0..1 of the window).
        posY: ignored.
        sizeX: ignored.
        sizeY: ignored.
        options: ignored.

    Returns:
        The view's handle.
    """
    return _gui_handle(ctx)


@sim_function("floatingViewRemove")
def floatingViewRemove(ctx: CallContext, floatingViewHandle: Any) -> int:  # noqa: N802, N803
    """``sim.floatingViewRemove``: no view to remove (headless).

    Args:
        floatingViewHandle: ignored.

    Returns:
        1.

    """
    return 1


@sim_function("adjustView")
def adjustView(ctx: CallContext, viewHandleOrIndex: Any, objectHandle: Any, options: Any, viewLabel: Any = None) -> int:  # noqa: N802, N803
    """``sim.adjustView``: no view to adjust (headless).

    Args:
        viewHandleOrIndex: ignored.
        objectHandle: ignored.
        options: ignored.
        viewLabel: ignored.

    Returns:
        0.

    """
    return 0


@sim_function("cameraFitToView")
def cameraFitToView(ctx: CallContext, viewHandleOrIndex: Any, objectHandles: Any = None, options: Any = 0,  # noqa: N802, N803
                    scaling: Any = 1.0) -> int:
    """``sim.cameraFitToView``: no view to fit (headless).

    Args:
        viewHandleOrIndex: ignored.
        objectHandles: ignored.
        options: ignored.
        scaling: ignored.

    Returns:
        0.

    """
    return 0


@sim_function("getPage")
def getPage(ctx: CallContext) -> int:  # noqa: N802
    """``sim.getPage``: page 0 (headless).

    Returns:
        0.

    """
    return 0


@sim_function("setPage")
def setPage(ctx: CallContext, pageIndex: Any) -> None:  # noqa: N802, N803
    """``sim.setPage``: no pages (headless).

    Args:
        pageIndex: the page, checked and ignored.

    Raises:
        ArgumentError: ``pageIndex`` is not an integer.

    """
    _int(pageIndex, "pageIndex")


@sim_function("getNavigationMode")
def getNavigationMode(ctx: CallContext) -> int:  # noqa: N802
    """``sim.getNavigationMode``: mode 0 (headless).

    Returns:
        0.

    """
    return 0


@sim_function("setNavigationMode")
def setNavigationMode(ctx: CallContext, navigationMode: Any) -> None:  # noqa: N802, N803
    """``sim.setNavigationMode``: no navigation (headless).

    Args:
        navigationMode: a ``sim.navigation_*`` value, checked and ignored.

    Raises:
        ArgumentError: ``navigationMode`` is not an integer.

    """
    _int(navigationMode, "navigationMode")


@sim_function("refreshDialogs")
def refreshDialogs(ctx: CallContext, refreshDegree: Any) -> int:  # noqa: N802, N803
    """``sim.refreshDialogs``: no dialogs (headless).

    Args:
        refreshDegree: ignored.

    Returns:
        0.

    """
    return 0


@sim_function("announceSceneContentChange")
def announceSceneContentChange(ctx: CallContext) -> int:  # noqa: N802
    """0: no undo buffer without a window.

    ``sim.announceSceneContentChange``.

    Returns:
        0.
    """
    return 0


@sim_function("getObjectSelection")
def getObjectSelection(ctx: CallContext) -> list[int]:  # noqa: N802
    """The selected objects' handles (no GUI: what scripts and clients set).

    ``sim.getObjectSelection``.

    Returns:
        The handles, in selection order.
    """
    sim = ctx.view
    return list(getattr(sim, "selection", []) or [])


@sim_function("setObjectSelection")
def setObjectSelection(ctx: CallContext, objectHandles: Any) -> None:  # noqa: N802, N803
    """``sim.setObjectSelection``: the selection :func:`getObjectSelection` answers.

    Args:
        objectHandles: list of object handles.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a list of integers.
        UnsupportedError: no simulation behind the script.

    """
    sim = ctx.simulation("setObjectSelection")
    sim.selection = [ctx.world.get(ctx.h(h, "objectHandle")).handle for h in objectHandles]




def _selection_targets(ctx: CallContext, what: int, handle: Any) -> list[int]:
    """The objects ``sim_handle_single`` / ``_tree`` / ``_chain`` / ``_all`` name around ``handle``."""
    w = ctx.world
    if what == -2:  # sim_handle_all
        return list(w.objects)
    h = w.get(ctx.h(handle, "objectHandle")).handle
    if what == -6:  # sim_handle_tree: the object and every object below it
        found, todo = [], [h]
        while todo:
            cur = todo.pop()
            found.append(cur)
            todo.extend(o.handle for o in w.objects.values() if o.parent == cur)
        return found
    if what == -7:  # sim_handle_chain: the object and every object above it
        chain = [h]
        while w.objects[chain[-1]].parent != -1 and len(chain) <= len(w.objects):
            chain.append(w.objects[chain[-1]].parent)
        return chain
    if what == -8:  # sim_handle_single
        return [h]
    raise ArgumentError(f"what must be sim.handle_single, _tree, _chain or _all, got {what}")


@sim_function("addObjectToSelection")
def addObjectToSelection(ctx: CallContext, what: Any, objectHandle: Any = None) -> int:  # noqa: N802, N803
    """V-REP 3.x's ``simAddObjectToSelection(what, objectHandle)``: the object (``sim.handle_single``),
    its tree (``sim.handle_tree``), its chain of parents (``sim.handle_chain``) or every object
    (``sim.handle_all``) join the selection :func:`getObjectSelection` answers (coppeliaSimLib
    ``simAddObjectToSelection_internal``).

    Args:
        what: ``sim.handle_single``, ``_tree``, ``_chain`` or ``_all``.
        objectHandle: the object (ignored for ``sim.handle_all``).

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: another ``what``.
    """
    sim = ctx.simulation("addObjectToSelection")
    current = list(getattr(sim, "selection", []) or [])
    sim.selection = current + [h for h in _selection_targets(ctx, _int(what, "what"), objectHandle) if h not in current]
    return 1


@sim_function("removeObjectFromSelection")
def removeObjectFromSelection(ctx: CallContext, what: Any, objectHandle: Any = None) -> int:  # noqa: N802, N803
    """V-REP 3.x's ``simRemoveObjectFromSelection(what, objectHandle)``: as
    :func:`addObjectToSelection`, the objects leave the selection (``sim.handle_all``: all of them;
    coppeliaSimLib ``simRemoveObjectFromSelection_internal``).

    Args:
        what: ``sim.handle_single``, ``_tree``, ``_chain`` or ``_all``.
        objectHandle: the object (ignored for ``sim.handle_all``).

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: another ``what``.
    """
    sim = ctx.simulation("removeObjectFromSelection")
    gone = set(_selection_targets(ctx, _int(what, "what"), objectHandle))
    sim.selection = [h for h in (getattr(sim, "selection", []) or []) if h not in gone]
    return 1


@sim_function("isObjectInSelection")
def isObjectInSelection(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """V-REP 3.x's ``simIsObjectInSelection``: 1 when the object is selected, else 0.

    Args:
        objectHandle: the object's handle.

    Returns:
        1 or 0.

    Raises:
        UnknownObjectError: no such object.
    """
    h = ctx.world.get(ctx.h(objectHandle, "objectHandle")).handle
    return int(h in (getattr(ctx.view, "selection", []) or []))
