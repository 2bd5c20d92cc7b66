"""The drop-in client survives its server and its caller (issue 11, defects 10 and 11).

Defect 10: when the server goes (killed, or stopped longer than Zenoh's lease), the client
clears its inbox as the legacy client did (extApi.c, ``_communicationThread``: on disconnection
``_messageReceived_dataSize = 0`` and the connection id turns -1), so ``buffer`` reads answer
"no value" instead of stale data; a client started with ``doNotReconnectOnceDisconnected``
stays disconnected, a reconnecting one gets fresh stream data once the server is back.

Defect 11: no argument a legacy program passes makes a ``simx*`` function raise, and none makes
the server answer with an internal error.
"""

from __future__ import annotations

import os
import signal

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client import constants as C

B = vrep.simx_opmode_blocking
S = vrep.simx_opmode_streaming
BUF = vrep.simx_opmode_buffer
LEASE_MS = 1000  # Zenoh lease of the server under test: it is seen gone 1 s after it froze


def _lease_config(tmp_path, ports: list[int]) -> str:
    """A server Zenoh config with a short lease (the default is 10 s), loopback only. It names
    its endpoints: the server keeps a file's listen endpoints (Zenoh's defaults if it has none)."""
    path = tmp_path / "lease.json5"
    endpoints = ", ".join(f'"tcp/127.0.0.1:{p}"' for p in ports)
    path.write_text(f'{{ listen: {{ endpoints: [{endpoints}] }}, scouting: {{ multicast: {{ enabled: false }} }},'
                    f' transport: {{ link: {{ tx: {{ lease: {LEASE_MS}, keep_alive: 4 }} }} }} }}')
    return str(path)


def _start(port: int, reconnect: bool) -> int:
    # simxStart(address, port, waitUntilConnected, doNotReconnectOnceDisconnected, timeOutInMs,
    # commThreadCycleInMs); a negative time out is the blocking-call time out (here 1 s).
    cid = vrep.simxStart("127.0.0.1", port, True, not reconnect, -1000, 5)
    assert cid >= 0, f"could not connect to the server on port {port}"
    return cid


def _joint(cid: int) -> int:
    rc, j = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
    assert rc == 0
    return j


def _streamed(cid: int, j: int, value: float) -> None:
    """Wait until the buffered stream of joint j carries ``value`` (set by a blocking call)."""
    assert vrep.simxSetJointPosition(cid, j, value, B) == 0
    wait_until(lambda: (lambda r: r[0] == 0 and abs(r[1] - value) < 1e-4)(
        vrep.simxGetJointPosition(cid, j, BUF)), 10, 0.01, f"the stream showing {value}")


def _outage_reads(cid: int, j: int) -> tuple[int, ...]:
    """What a disconnected client answers: buffer read, oneshot, streaming, blocking, remove."""
    return (vrep.simxGetJointPosition(cid, j, BUF)[0], vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_oneshot)[0],
            vrep.simxGetJointPosition(cid, j, S)[0], vrep.simxGetJointPosition(cid, j, B)[0],
            vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_remove)[0])


NOVALUE, TIMEOUT = C.simx_return_novalue_flag, C.simx_return_timeout_flag | C.simx_return_novalue_flag
OUTAGE = (NOVALUE, NOVALUE, NOVALUE, TIMEOUT, NOVALUE)  # legacy codes of a client with an empty inbox


def _check_outage(stays: int, back: int, j: int, what: str) -> None:
    """Both clients see the server gone: connection id -1, no stale value, legacy codes."""
    for cid in (stays, back):
        wait_until(lambda: vrep.simxGetConnectionId(cid) == -1, 10, 0.02, f"connection id -1 ({what})")
        # The inbox was cleared: the last streamed value is not handed out as fresh.
        assert vrep.simxGetJointPosition(cid, j, BUF)[0] == NOVALUE
    assert _outage_reads(stays, j) == OUTAGE
    assert vrep.simxGetJointPosition(back, j, BUF)[0] == NOVALUE


def _check_recovery(stays: int, back: int, j: int, first_id: int) -> None:
    """The reconnecting client streams fresh data again; the other one stays disconnected."""
    stale = []

    def reconnected() -> bool:
        rc, _ = vrep.simxGetJointPosition(back, j, BUF)
        if vrep.simxGetConnectionId(back) == -1 and rc == 0:
            stale.append(rc)  # a value while disconnected can only be stale
        return vrep.simxGetConnectionId(back) not in (-1, first_id)

    wait_until(reconnected, 20, 0.02, "the reconnecting client's new connection id")
    assert not stale
    _streamed(back, j, -0.25)  # its stream resumed by itself and carries values set now
    assert vrep.simxGetConnectionId(stays) == -1
    assert _outage_reads(stays, j) == OUTAGE  # a server that is back answers nothing to it
    assert vrep.simxSetJointPosition(stays, j, 0.1, B) == TIMEOUT
    assert vrep.simxGetJointPosition(back, j, B)[0] == 0  # ... so the joint did not move
    assert abs(vrep.simxGetJointPosition(back, j, B)[1] + 0.25) < 1e-4


def test_killed_and_restarted_server(tmp_path):
    """SIGKILL, then a new server on the same ports: the inbox is cleared at once; the
    reconnecting client streams again (values of the new server), the other stays at -1."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", ports=ports)
    stays = back = -1
    try:
        stays, back = _start(ports[0], reconnect=False), _start(ports[1], reconnect=True)
        j = _joint(back)
        first_id = vrep.simxGetConnectionId(back)
        for cid in (stays, back):
            assert vrep.simxGetJointPosition(cid, j, S)[0] in (0, 1)
        _streamed(back, j, 0.5)
        wait_until(lambda: vrep.simxGetJointPosition(stays, j, BUF) [0] == 0, 10, 0.01, "the other stream")
        srv.proc.kill()
        srv.proc.wait()
        _check_outage(stays, back, j, "after SIGKILL")
        srv.stop()
        srv = ServerProcess(str(SCENE), "--stopped", ports=ports)
        # The new server starts from the scene: joint 1 at 0, never the old 0.5.
        wait_until(lambda: vrep.simxGetConnectionId(back) not in (-1, first_id), 20, 0.02, "reconnection")
        wait_until(lambda: vrep.simxGetJointPosition(back, j, BUF)[0] == 0, 10, 0.01, "fresh stream data")
        assert abs(vrep.simxGetJointPosition(back, j, BUF)[1]) < 1e-4
        _check_recovery(stays, back, j, first_id)
    finally:
        vrep.simxFinish(stays)
        vrep.simxFinish(back)
        srv.stop()


def test_server_frozen_past_its_lease(tmp_path):
    """SIGSTOP for longer than the Zenoh lease: the clients see the server gone and clear their
    inbox; after SIGCONT the reconnecting client streams again, the other stays at -1."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", "--zenoh-config", _lease_config(tmp_path, ports), ports=ports)
    stays = back = -1
    try:
        stays, back = _start(ports[0], reconnect=False), _start(ports[1], reconnect=True)
        j = _joint(back)
        first_id = vrep.simxGetConnectionId(back)
        for cid in (stays, back):
            assert vrep.simxGetJointPosition(cid, j, S)[0] in (0, 1)
        _streamed(back, j, 0.5)
        wait_until(lambda: vrep.simxGetJointPosition(stays, j, BUF)[0] == 0, 10, 0.01, "the other stream")
        os.kill(srv.proc.pid, signal.SIGSTOP)
        try:
            _check_outage(stays, back, j, "while the server is stopped")
        finally:
            os.kill(srv.proc.pid, signal.SIGCONT)
        _check_recovery(stays, back, j, first_id)
    finally:
        if srv.proc.poll() is None:
            os.kill(srv.proc.pid, signal.SIGCONT)
        vrep.simxFinish(stays)
        vrep.simxFinish(back)
        srv.stop()
