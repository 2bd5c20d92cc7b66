"""The run-control commands: handshake, ping, start / pause / stop, and the GUI-only calls
(custom UIs, dialogs) that a headless server refuses. Every handler is a
:data:`~simx_server.commands.handler.Handler`, ``(simulation, args) -> result``."""

from __future__ import annotations

from simx_wire.protocol import PROTOCOL_VERSION, UnsupportedError
from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation


def hello(sim: Simulation, args: list) -> dict:
    """Handshake: the scene and protocol the server runs."""
    return {
        "protocol": PROTOCOL_VERSION,
        "scene": sim.world.scene_name,
        "objects": len(sim.world.objects),
        "dt": sim.world.dt,
    }


def gui_only(name: str) -> Handler:
    """Handler for a call that needs V-REP's GUI (custom UIs, dialogs): always a remote error."""

    def handler(sim: Simulation, args: list) -> None:
        raise UnsupportedError(f"simx{name} needs V-REP's graphical user interface; simx is headless")

    return handler


GUI_ONLY = ("LoadUI", "GetUIHandle", "GetUISlider", "SetUISlider", "GetUIEventButton", "GetUIButtonProperty",
            "SetUIButtonProperty", "SetUIButtonLabel", "RemoveUI", "DisplayDialog", "EndDialog",
            "GetDialogInput", "GetDialogResult")


def start_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.start()


def stop_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.stop()


def pause_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.pause()


def get_ping_time(sim: Simulation, args: list) -> None:
    """A no-op executed in order with the others: its round trip is the ping time."""
    _args(args)



#: Command name -> handler: the handshake, ping, run state and GUI-only calls.
SIMULATION_HANDLERS: dict[str, Handler] = {
    "Hello": hello,
    "GetPingTime": get_ping_time,
    "StartSimulation": start_simulation,
    "StopSimulation": stop_simulation,
    "PauseSimulation": pause_simulation,
    **{name: gui_only(name) for name in GUI_ONLY},
}
