"""Every ZMQ call that reaches the scene's editor is charged as an edit (issue 84, item 4): the
door's hand list of edit calls missed ``createShape``, ``copyPasteObjects``, ``setLinkDummy``,
``createProximitySensor``, ``setJointDependency``, ``scaleObject``..., whose recompiles then cost
their connection nothing. Now the charge follows the editor's own count of the calls that
reached it (``Editor.edits``). In-process, with a real simulation."""

from __future__ import annotations

import cbor2
import pytest

from simx_server.base import limits
from simx_server.loop.clients import Clients
from simx_server.scene.simulation import Simulation
from simx_server.zmq import codec
from simx_server.zmq.frontend import Incoming
from simx_server.zmq.service import ZmqService

SCENE = """<mujoco model="edit charges">
  <worldbody>
    <body name="Box" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="Arm" pos="0 0.5 0.1">
      <joint name="J1" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.2 0.02 0.02" pos="0.2 0 0"/>
      <body name="Fore" pos="0.4 0 0">
        <joint name="J2" type="hinge" axis="0 0 1"/>
        <geom type="box" size="0.1 0.02 0.02" pos="0.1 0 0"/>
      </body>
    </body>
    <site name="D1" pos="1 0 0.1"/>
    <site name="D2" pos="1 0.1 0.1"/>
  </worldbody>
</mujoco>
"""

#: name -> (func, args with handles by object name): calls that reach the editor
EDIT_CALLS = {
    "createShape": ("sim.createShape", [0, 0.0, [0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1], [0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2]]),
    "copyPasteObjects": ("sim.copyPasteObjects", [["Box"]]),
    "setLinkDummy": ("sim.setLinkDummy", ["D1", "D2"]),
    "createProximitySensor": ("sim.createProximitySensor", [34, 34, 0, [], [0.0, 1.0]]),
    "setJointDependency": ("sim.setJointDependency", ["J2", "J1", 0.0, 1.0]),
    "scaleObject": ("sim.scaleObject", ["Box", 2.0, 2.0, 2.0]),
}


@pytest.fixture
def service(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "EDIT_DEBT_SECONDS", 1e9)  # charges pile up; nothing waits
    monkeypatch.setattr(limits, "MAX_REQUEST_SECONDS", 1e9)  # another call costs nothing
    (tmp_path / "scene.xml").write_text(SCENE)
    sim = Simulation(tmp_path / "scene.xml")
    sent: list = []
    server = type("Server", (), {"sim": sim, "clients": Clients(), "hold_pass": lambda self, client, seconds: None})()
    frontend = type("Frontend", (), {"send": lambda self, env, payload, **_: sent.append(cbor2.loads(payload))})()
    made = ZmqService(server, frontend)
    made.sent = sent
    yield made
    sim.close()


def _call(service: ZmqService, connection: bytes, func: str, args: list) -> dict:
    service.handle("zmq", Incoming([connection], codec.read_request(codec.encode_request(func, args, "client")),
                                   len(connection), 10))
    return service.sent[-1]


def _handles(service: ZmqService, args: list) -> list:
    """Object names in ``args`` as their handles (a string is an object's name)."""
    def one(a):
        if isinstance(a, str):
            return _call(service, b"lookup", "sim.getObject", ["/" + a])["ret"][0]
        if isinstance(a, list) and a and all(isinstance(x, str) for x in a):
            return [one(x) for x in a]
        return a
    return [one(a) for a in args]


@pytest.mark.parametrize("name", list(EDIT_CALLS))
def test_a_call_that_reached_the_editor_is_charged_as_an_edit(service, name):
    func, args = EDIT_CALLS[name]
    args = _handles(service, args)
    edits = service.sim.editor.edits
    reply = _call(service, name.encode(), func, args)
    assert "ret" in reply, reply
    assert service.sim.editor.edits > edits  # it reached the editor
    assert service.connections[name.encode()].debt > 0  # its duration, owed by its connection
    assert func in service.edit_calls  # and the socket thread no longer serves it in place


def test_a_call_that_does_not_reach_the_editor_costs_nothing(service):
    box = _handles(service, ["Box"])[0]
    assert "ret" in _call(service, b"reader", "sim.getObjectPosition", [box, -1])
    assert service.connections[b"reader"].debt == 0 and not service.edit_calls


def test_a_legacy_command_that_reached_the_editor_is_charged_to_its_clients_share(service):
    """The legacy door's rule: a command outside the edit commands (a script function called by
    ``simxCallScriptFunction`` that edits the scene) that reached the editor is charged to its
    client's share too (``LegacyDoor._run``, its own executor replaced by one that edits)."""
    from types import SimpleNamespace

    from simx_server.legacy.server import LegacyDoor
    from simx_server.loop.budgets import Share

    sim = service.sim
    entry = SimpleNamespace(share=Share(0.0))
    door = SimpleNamespace(sim=sim, _join=lambda client: entry, _edit=None,
                           _execute=lambda client, name, mode, args: [True, sim.editor.create_dummy(0.01, None)
                                                                      if name == "CallScriptFunction" else 0])
    LegacyDoor._run(door, "c", [["GetPingTime", 0, []]])
    assert entry.share.debt == 0
    LegacyDoor._run(door, "c", [["CallScriptFunction", 0, []]])
    assert entry.share.debt > 0
