"""What simx implements of CoppeliaSim 4.x's ``sim`` (442 functions), ``simIK`` (76) and its vision
plug-in's ``simVision`` (46), from the code: a function is
**implemented** when the API table (:data:`simx_server.api.registry.SIM` /
:data:`~simx_server.api.registry.SIMIK` / ``SIMVISION``, which child scripts and ZMQ clients share) or the ZMQ
service's stepping calls have it; **headless** when it is one of the window functions answered as
a headless CoppeliaSim does (the functions of :mod:`simx_server.api.sim.gui`).
Every other function has an entry in :data:`NOT_IMPLEMENTED`: ``("n/a", why)`` where it has no
meaning for a headless MuJoCo server (the main script's own steps, plugins, callbacks into a
client), ``("refused", why)`` where the server refuses it by design (docs/SECURITY.md), or
``("missing", why)`` where it has a meaning simx does not give it yet.

``scripts/gen_coverage.py`` writes docs/COVERAGE.md from :func:`table`; tests/scripts/test_coverage.py
checks the file is current and every function has its status.
"""

from __future__ import annotations

from simx_server.api import SIM, SIMIK, SIMVISION, Callers, names
from simx_server.zmq.service import STEPPING

_MAIN = "the main script's own step: simx's loop runs it (sensing, dynamics, scripts) every step"
_PLUGIN = "CoppeliaSim's plugins do not exist in simx (MuJoCo is built in)"
_CALLBACK = "takes a Lua/Python callback into the caller: a ZMQ client's function cannot be called back"
_SECURITY = "refused by design: a script or client may not reach the host (docs/SECURITY.md)"
_TEXTURE = ("textures changed in place at run time: MuJoCo uploads a texture to the renderer once "
            "(new textures come with a recompile: createTexture)")
_GRAPH = "a graph's display settings (colours, flags): simx keeps its streams and curves, not a view of them"
_MESH_EDIT = "mesh surgery at run time (MjSpec could do it; not done yet)"

#: Functions of CoppeliaSim's 4.x table that simx does not implement: (status, why).
NOT_IMPLEMENTED: dict[str, tuple[str, str]] = {
    **{n: ("n/a", _MAIN) for n in ("handleAddOnScripts", "handleDynamics", "handleEmbeddedScripts", "handleExtCalls",
                                   "handleJointMotion", "handleSandboxScript", "handleSensingStart",
                                   "handleSimulationStart", "initScript", "moduleEntry",
                                   "fastIdleLoop", "handleGraph", "resetGraph")},
    **{n: ("n/a", _PLUGIN) for n in ("getLoadedPlugins", "getPluginInfo", "getPluginName", "isPluginLoaded",
                                     "loadPlugin", "setPluginInfo", "registerScriptFuncHook")},
    **{n: ("n/a", _CALLBACK) for n in ("visitTree", "scheduleExecution", "cancelScheduledExecution", "testCB",
                                       "Object")},
    **{n: ("refused", _SECURITY) for n in ("launchExecutable", "serialOpen", "serialClose", "serialCheck", "serialRead",
                                           "serialSend", "executeLuaCode", "executeScriptString", "systemSemaphore",
                                           "createScript", "persistentDataRead", "persistentDataWrite",
                                           "getPersistentDataTags", "getMatchingPersistentDataTags")},
    "writeTexture": ("missing", _TEXTURE),
    "getGraphInfo": ("missing", _GRAPH),
    **{n: ("missing", _MESH_EDIT) for n in ("generateShapeFromPath", "generateTextShape")},
    "createJoint": ("missing", "a joint alone at the world origin: a MuJoCo joint needs the body it moves "
                               "(make the body, then the joint, in MJCF)"),
    "setObjectHierarchyOrder": ("missing", "MjSpec cannot reorder a body's children in place"),
    **{n: ("missing", "no writable string or float-array parameter is mapped (the readable ones are)")
       for n in ("setObjectFloatArrayParam", "setObjectStringParam")},
    **{n: ("n/a", "the event stream of CoppeliaSim's user interfaces: no UI") for n in (
        "getGenesisEvents", "pushUserEvent", "setEventFilters")},
    "getScriptFunctions": ("n/a", "the official client answers it itself (a proxy object; docs/ZMQ.md)"),
}

#: simIK functions simx does not implement: (status, why).
IK_NOT_IMPLEMENTED: dict[str, tuple[str, str]] = {
    "createJoint": ("missing", "an environment's joints are the scene's (MuJoCo's): its own dummies are served, "
                               "joints of its own would need kinematics beside MuJoCo's"),
    "setJointScrewLead": ("missing", "a MuJoCo hinge cannot translate along its axis: no screw joints"),
}


_VELODYNE = ("a rotating scanner the plug-in assembles from 4 sensors it handles itself: not done yet "
             "(a script's velodyneDataFromWorkImg is)")
#: simVision functions simx does not implement: (status, why).
VISION_NOT_IMPLEMENTED: dict[str, tuple[str, str]] = {
    **{n: ("missing", _VELODYNE) for n in ("createVelodyneHDL64E", "createVelodyneVPL16", "destroyVelodyneHDL64E",
                                           "destroyVelodyneVPL16", "handleVelodyneHDL64E", "handleVelodyneVPL16")},
    "distort": ("missing", "a lens distortion of the image by a pixel map: not done yet"),
    "handleSpherical": ("missing", "a spherical image assembled from 6 sensors: not done yet (the pyrep package's "
                                   "spherical sensor assembles its own)"),
    "handleAnaglyphStereo": ("missing", "a red-cyan image of 2 sensors: not done yet"),
}


def _status(name: str, implemented: set[str], missing: dict[str, tuple[str, str]], gui: set[str]) -> tuple[str, str]:
    if name in implemented:
        return ("headless", "answered as a headless CoppeliaSim (no window)") if name in gui else ("implemented", "")
    return missing.get(name, ("missing", "no entry in simx_server/zmq/coverage.py"))


def table() -> dict[str, list[tuple[str, str, str]]]:
    """``{namespace: [(name, status, why)]}`` for every function of CoppeliaSim's 4.x tables."""
    gui = {n for n in SIM if SIM[n].module == "simx_server.api.sim.gui"}
    sim_impl = set(SIM.names(Callers.CLIENTS)) | set(STEPPING)
    out = {"sim": [(n, *_status(n, sim_impl, NOT_IMPLEMENTED, gui)) for n in sorted(names.current_functions("sim"))],
           "simIK": [(n, *_status(n, set(SIMIK.names(Callers.CLIENTS)), IK_NOT_IMPLEMENTED, set()))
                     for n in sorted(names.current_functions("simIK"))],
           "simVision": [(n, *_status(n, set(SIMVISION.names(Callers.CLIENTS)), VISION_NOT_IMPLEMENTED, set()))
                         for n in sorted(names.current_functions("simVision"))]}
    return out


def summary(rows: list[tuple[str, str, str]]) -> dict[str, float]:
    """Counts per status and the share implemented of the functions with a headless meaning
    (implemented + headless, over all but n/a and refused)."""
    counts: dict[str, float] = {}
    for _, status, _ in rows:
        counts[status] = counts.get(status, 0) + 1
    meaningful = len(rows) - counts.get("n/a", 0) - counts.get("refused", 0)
    done = counts.get("implemented", 0) + counts.get("headless", 0)
    counts["share"] = done / meaningful if meaningful else 1.0
    return counts


def markdown() -> str:
    """docs/COVERAGE.md."""
    lines = ["# CoppeliaSim 4.x API coverage", "",
             "Generated from the code by `scripts/gen_coverage.py` (`simx_server/zmq/coverage.py`); "
             "tests/scripts/test_coverage.py keeps it current. One implementation serves ZMQ clients, Lua "
             "and Python child scripts ([ZMQ.md](ZMQ.md), [SCRIPTS.md](SCRIPTS.md)). Statuses: "
             "**implemented** (does the real thing on MuJoCo), **headless** (a window function, answered as a "
             "headless CoppeliaSim: console text to the log, neutral values), **n/a** (no meaning for a headless "
             "MuJoCo server), **refused** (by design, docs/SECURITY.md), **missing** (has a meaning, not done; "
             "calling it answers an error naming it). The share counts implemented and headless functions over "
             "all but n/a and refused.", ""]
    for ns, rows in table().items():
        s = summary(rows)
        parts = ", ".join(f"{k} {int(v)}" for k, v in sorted(s.items()) if k != "share")
        lines += [f"## `{ns}`: {len(rows)} functions", "",
                  f"{parts}; implemented share **{100 * s['share']:.1f} %**.", "",
                  "| function | status | why not |", "|---|---|---|"]
        lines += [f"| `{ns}.{n}` | {st} | {why} |" for n, st, why in rows]
        lines.append("")
    return "\n".join(lines)
