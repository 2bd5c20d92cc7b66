"""V-REP 3.x's wireless data between scripts: ``simSendData`` / ``simReceiveData``.

A script broadcasts a packet from an antenna (an object, default its own) to the scripts of a
target: ``sim.handle_all`` (every script), ``sim.handle_tree`` (the scripts of the objects below
the sender's object), ``sim.handle_chain`` (those of the objects above it) or one script (its
object's handle: scripts are named by their objects in simx). A receiver gets the packet when
its own antenna (default its object) lies within ``actionRadius`` (m) of the emitting antenna and
inside its emission angles: ``emissionAngle1`` (rad, 0..pi) the vertical opening about the
antenna's x-y plane, ``emissionAngle2`` (rad, 0..2 pi) the horizontal one about its x axis.
A script never receives its own packets.

Packets are read in the simulation passes after the one that sent them (a pass is one step's
``sysCall_actuation`` .. ``sysCall_sensing``): with ``persistence`` 0 only in the next pass, as
in V-REP (whose packets lived 1.5 time steps); with ``persistence`` > 0 while the simulation time
is within ``persistence`` s of the sending. ``simReceiveData(dataHeader, dataName, antenna,
index)`` returns ``data, senderId, dataHeader, dataName`` of the first matching packet (``index``
>= 0: the index-th), nil when there is none; a header of -1 and a nil name match any.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text


#: Packets kept at most (the oldest go first): bounds the server's memory.
MAX_PACKETS = 10_000
MAX_PACKET_BYTES = 1 << 20


@dataclass
class _Packet:
    sender: int
    target: int
    header: int
    name: str
    data: bytes
    antenna: np.ndarray  # 3x4 world matrix of the emitting antenna
    radius: float
    angle1: float
    angle2: float
    sent_pass: int
    sent_time: float
    persistence: float


# ``sim.sendData`` / ``sim.receiveData``.

def _wireless(ctx: CallContext) -> tuple[list, int]:
    me = ctx.script
    shared = me.shared if me is not None else ctx.state.own_shared
    return shared.setdefault("wireless", []), int(shared.get("pass", 0))


def _antenna(ctx: CallContext, handle: Any) -> np.ndarray:
    h = ctx.h(handle, "antennaHandle")
    return np.asarray(ctx.sim.getObjectMatrix(ctx.owner if h == C.sim_handle_self else h, -1),
                      dtype=float).reshape(3, 4)


@sim_function("sendData")
def sendData(ctx: CallContext, targetID: Any, dataHeader: Any, dataName: Any, data: Any,  # noqa: N802, N803
             antennaHandle: Any = C.sim_handle_self, actionRadius: Any = 100.0,  # noqa: N803
             emissionAngle1: Any = math.pi, emissionAngle2: Any = 2 * math.pi,  # noqa: N803
             persistence: Any = 0.0) -> int:
    """Broadcast ``data`` (bytes) to ``targetID``'s scripts (see the module); returns 1."""
    target = _int(targetID, "targetID")
    raw = _bytes(data, "data")
    if len(raw) > MAX_PACKET_BYTES:
        raise ArgumentError(f"sendData: {len(raw)} bytes; at most {MAX_PACKET_BYTES}")
    if target not in (C.sim_handle_all, C.sim_handle_tree, C.sim_handle_chain):
        ctx.world.get(target)  # a script's object: raises for an unknown one
    packets, now_pass = _wireless(ctx)
    packets.append(_Packet(ctx.owner, target, _int(dataHeader, "dataHeader"), _text(dataName, "dataName"), raw,
                           _antenna(ctx, antennaHandle), _num(actionRadius, "actionRadius"),
                           _num(emissionAngle1, "emissionAngle1"), _num(emissionAngle2, "emissionAngle2"),
                           now_pass, float(ctx.sim.getSimulationTime()), max(0.0, _num(persistence, "persistence"))))
    del packets[:-MAX_PACKETS]
    return 1


def _ancestors(ctx: CallContext, handle: int) -> set[int]:
    out, h = set(), handle
    while h >= 0:
        h = ctx.world.get(h).parent
        if h >= 0:
            out.add(h)
    return out


def _reaches(ctx: CallContext, p: _Packet, receiver: int, antenna: np.ndarray) -> bool:
    if p.sender == receiver:
        return False
    if p.target == C.sim_handle_tree and p.sender not in _ancestors(ctx, receiver):
        return False
    if p.target == C.sim_handle_chain and receiver not in _ancestors(ctx, p.sender):
        return False
    if p.target >= 0 and p.target != receiver:
        return False
    rel = p.antenna[:, :3].T @ (antenna[:, 3] - p.antenna[:, 3])  # in the emitter's frame
    dist = float(np.linalg.norm(rel))
    if dist > p.radius:
        return False
    if dist == 0.0:
        return True
    vertical = math.asin(max(-1.0, min(1.0, rel[2] / dist)))
    horizontal = math.atan2(rel[1], rel[0])
    return abs(vertical) <= p.angle1 / 2 + 1e-12 and abs(horizontal) <= p.angle2 / 2 + 1e-12


@sim_function("receiveData")
def receiveData(ctx: CallContext, dataHeader: Any = -1, dataName: Any = None,  # noqa: N802, N803
                antennaHandle: Any = C.sim_handle_self, index: Any = -1) -> Any:  # noqa: N803
    """The first packet for this script that matches (see the module), as
    ``data, senderId, dataHeader, dataName``; nil when there is none."""
    header = _int(dataHeader, "dataHeader")
    name = None if dataName is None else _text(dataName, "dataName")
    want = _int(index, "index")
    packets, now_pass = _wireless(ctx)
    now = float(ctx.sim.getSimulationTime())
    alive = [p for p in packets if now_pass == p.sent_pass + 1 or
             (p.persistence > 0 and now <= p.sent_time + p.persistence + 1e-9) or now_pass <= p.sent_pass]
    packets[:] = alive  # expired packets go
    antenna = _antenna(ctx, antennaHandle)
    found = [p for p in alive if p.sent_pass < now_pass and (header == -1 or p.header == header)
             and (name is None or p.name == name) and _reaches(ctx, p, ctx.owner, antenna)]
    if not found or want >= len(found):
        return None
    p = found[max(0, want)]
    return p.data, p.sender, p.header, p.name


