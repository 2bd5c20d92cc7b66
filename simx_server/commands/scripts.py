"""Script commands: ``simxCallScriptFunction`` into the scene's child scripts
(:mod:`simx_server.scripts`). Every handler is ``(simulation, args) -> result``."""

from __future__ import annotations

from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation


def call_script_function(sim: Simulation, args: list) -> list:
    obj, stype, fn, ints, floats, strings, buf = _args(args, "str", "int", "str", "any", "any", "any", "any")
    try:
        with sim.editor.files.on_behalf():  # the script's file calls act as the calling client
            return sim.scripts.call(obj, stype, fn, ints, floats, strings, buf)
    finally:
        sim.apply_requests()  # the function asked to stop or pause: now that it has returned



#: Command name -> handler: calls into child scripts.
SCRIPT_HANDLERS: dict[str, Handler] = {"CallScriptFunction": call_script_function}
