"""Which requests the legacy door serves as a lone ``simxSynchronousTrigger`` would be (in place,
when the simulation thread waits for work): a trigger carrying the commands its client's outbox
held (``simx_client``'s ``OutboxSender._carry``), at most ``protocol.MAX_CARRIED_COMMANDS`` of
them, none blocking, none editing the scene (issue 44)."""

from __future__ import annotations

import collections
from types import SimpleNamespace

import pytest

from simx_server.legacy.sessions import Sessions
from simx_wire import protocol as P

B, ONESHOT, STREAMING = P.MODE_BLOCKING, P.MODE_ONESHOT, P.MODE_STREAMING
TRIGGER = ["SynchronousTrigger", B, []]


def head(*commands: list) -> SimpleNamespace:
    return SimpleNamespace(queue=collections.deque([((None, list(commands)), 0)]))


@pytest.mark.parametrize("commands, carried", [
    ([["SetJointTargetPosition", ONESHOT, [1, 0.5]], TRIGGER], True),
    ([["GetJointPosition", STREAMING, [1]], ["SetIntegerSignal", ONESHOT, ["s", 1]], TRIGGER], True),
    ([TRIGGER], False),  # a lone trigger: Sessions.blocking_head
    ([["SetIntegerSignal", ONESHOT, ["s", 1]]], False),
    ([TRIGGER, ["SetIntegerSignal", ONESHOT, ["s", 1]]], False),  # the trigger not last
    ([["GetPingTime", B, []], TRIGGER], False),  # another blocking call
    ([["SetIntegerSignal", ONESHOT, ["s", 1]], ["SynchronousTrigger", ONESHOT, []]], False),
    ([["LoadModel", ONESHOT, ["m.xml", 0]], TRIGGER], False),  # scene edits go round robin
    ([["SetIntegerSignal", ONESHOT, ["s", 1]]] * (P.MAX_CARRIED_COMMANDS + 1) + [TRIGGER], False),
    ([["SetIntegerSignal", ONESHOT, ["s", 1]]] * P.MAX_CARRIED_COMMANDS + [TRIGGER], True),
])
def test_carried_trigger(commands, carried):
    assert Sessions.carried_trigger(head(*commands)) is carried
    assert not Sessions.head_is_blocking(head(*commands)) or commands == [TRIGGER]  # pacing unchanged


def test_no_request_is_no_carried_trigger():
    assert Sessions.carried_trigger(SimpleNamespace(queue=collections.deque())) is False
