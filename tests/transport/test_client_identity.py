"""A client id names a client but does not make one (issue 48): on a server as it runs by
default (plain TCP on loopback, no access control), another session reads a legacy client's id
from its liveliness token, sees its requests (a queryable on every call key), and presents the
id: its erase, its handshake, its replay of the client's own request and its simxFinish are
all refused; the client's file stays, and the client goes on. The reproduction, before: the
erase removed the victim's file and the Bye under its id deleted its whole folder.
"""

from __future__ import annotations

import queue
import tempfile
from pathlib import Path

import msgpack
import pytest
import zenoh

import vrep
from conftest import ServerProcess, wait_until
from simx_client import api
from simx_client.connection import client_config
from simx_wire import proof as PR
from simx_wire import protocol as P

pytestmark = pytest.mark.renderers_on_demand
B = vrep.simx_opmode_blocking


def _ask(session: zenoh.Session, client: str, payload: bytes, attachment: bytes | None = None) -> object:
    """One query under ``client``'s call key: the decoded reply (a response list or a refusal map)."""
    replies = [r for r in session.get(P.call_key(P.DEFAULT_PREFIX, client), payload=payload, timeout=10,
                                      attachment=attachment) if r.ok is not None]
    assert len(replies) == 1, "one answer, the server's"
    return msgpack.unpackb(replies[0].ok.payload.to_bytes(), raw=False)


def _refused(answer: object) -> str:
    assert type(answer) is dict, f"refused, not executed: {answer!r}"
    return answer["err"]


def _files(srv: ServerProcess) -> list[str]:
    root = Path(tempfile.gettempdir())
    return sorted(p.name for p in root.glob(f"simx-{srv.proc.pid}-*/.simx-clients/*/*") if p.is_file())


def test_another_session_presenting_a_clients_id_cannot_act_as_it(tmp_path):
    srv = ServerProcess("--stopped", renderers="on-demand")
    (tmp_path / "keep.txt").write_text("alice's")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        alice = api._connections[cid].client
        assert vrep.simxTransferFile(cid, str(tmp_path / "keep.txt"), "keep.txt", 5, B) == 0
        assert _files(srv) == ["keep.txt"]
        with zenoh.open(client_config("127.0.0.1", srv.port)) as bob:
            ids = [str(r.ok.key_expr).rsplit("/", 1)[-1]
                   for r in bob.liveliness().get(P.client_token_prefix(), timeout=5) if r.ok is not None]
            assert ids == [alice], "the id is there for any session to read"
            seen: queue.SimpleQueue = queue.SimpleQueue()

            def snoop(query: zenoh.Query) -> None:
                if str(query.key_expr).endswith(alice):
                    att = query.attachment
                    seen.put((query.payload.to_bytes(), att.to_bytes() if att is not None else None))

            with bob.declare_queryable(P.call_keys(), snoop):  # reaches the router in its own time
                wait_until(lambda: vrep.simxGetPingTime(cid)[0] == 0 and not seen.empty(), what="a request seen")
                payload, proof = seen.get()  # alice's own request, as it went by
            assert proof is not None and len(proof) == PR.PROOF_BYTES
            erase = P.request(alice, [["EraseFile", B, ["keep.txt"]]])
            bye = P.request(alice, [["Bye", 0, []]])
            hello = P.request(alice, [["Hello", B, []]])
            refusals = [
                _refused(_ask(bob, alice, erase)),  # no proof
                _refused(_ask(bob, alice, hello)),  # a handshake of its own under the id
                _refused(_ask(bob, alice, erase, proof)),  # alice's proof on another payload
                _refused(_ask(bob, alice, payload, proof)),  # alice's request replayed
                _refused(_ask(bob, alice, bye, PR.seal(b"\0" * PR.SECRET_BYTES, 1 << 40, bye))),  # a guessed secret
                _refused(_ask(bob, alice, bye)),
            ]
            assert [r.split(":")[0] for r in refusals] == [PR.NOT_YOURS] * 6, refusals
            assert "used before" in refusals[3]
            assert all("/tmp" not in r for r in refusals)
        # alice is untouched: her file, her session, her folder.
        assert _files(srv) == ["keep.txt"]
        assert vrep.simxGetPingTime(cid)[0] == 0
        assert vrep.simxEraseFile(cid, "keep.txt", B) == 0
        assert _files(srv) == []
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "Traceback" not in log
    assert f"client {alice} disconnected" in log and log.count(f"client {alice} disconnected") == 1


def test_a_client_the_server_forgot_handshakes_again():
    """A proven request under an id the server does not know (here: after the server forgot the
    client at its Bye) is refused as unknown, and the client's connection handshakes again
    (a new secret) and is served."""
    srv = ServerProcess("--stopped", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        conn = api._connections[cid]
        old = conn._secret
        assert old is not None and len(old) == PR.SECRET_BYTES
        assert conn.request([["Bye", B, []]]) == [[True, None]]  # the server forgets it
        assert conn.request([["GetPingTime", B, []]]) == [[True, None]]
        assert conn._secret is not None and conn._secret != old
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "Traceback" not in log
    assert PR.UNKNOWN in log
