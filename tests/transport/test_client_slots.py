"""Issue 23 part 4: one Zenoh session cannot take every client slot.

One session that declared 1,100 liveliness tokens and sent one request under each id filled
``MAX_CLIENTS``: every new client got "server busy" until it left. A token now protects its
client only if the Zenoh session that answers the server's peer check for that id
(``protocol.peer_key``; the reply's ``replier_id``) holds fewer than
``limits.MAX_CLIENTS_PER_PEER`` protected ids (simx_server/legacy/peers.py).
"""

from __future__ import annotations

import queue
import uuid

import msgpack
import zenoh

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client import protocol as P
from simx_client.connection import Connection, client_config
from simx_server.base import limits as L
from simx_server.legacy.sessions import Sessions

B = vrep.simx_opmode_blocking


def _call(session: zenoh.Session, client: str) -> list:
    for reply in session.get(P.call_key("simx", client), payload=P.request(client, [["GetPingTime", B, []]]),
                             timeout=30):
        if reply.ok is not None:
            return msgpack.unpackb(reply.ok.payload.to_bytes(), raw=False)[5][0]
    return []


def test_one_session_with_1100_tokens_leaves_room_for_new_clients():
    server = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    flooder = zenoh.open(client_config("127.0.0.1", server.port))
    try:
        first = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)  # before the flood, then idle
        assert first >= 0 and vrep.simxGetPingTime(first)[0] == 0
        # The flooder answers every peer check (a wildcard queryable): it is named as the
        # session of all 1,100 ids, and of the first client's id too.
        checks = flooder.declare_queryable(P.peer_key("simx", "**"), lambda q: q.reply(q.key_expr, b""))
        tokens, served = [], 0
        for _ in range(L.MAX_CLIENTS + 76):
            client = uuid.uuid4().hex
            tokens.append(flooder.liveliness().declare_token(P.client_token_key("simx", client)))
            served += _call(flooder, client) == [True, None]
        assert served >= L.MAX_CLIENTS - 1, server.log_so_far()[-3000:]  # served until full, then the unprotected ones give way
        for _ in range(3):  # new clients still get in, each taking an unprotected flooder id's place
            newcomer = Connection("127.0.0.1", server.port)  # its own Zenoh session, as a program's
            try:
                assert newcomer.request([["GetPingTime", B, []]]) == [[True, None]]
            finally:
                newcomer.close()
        assert vrep.simxGetPingTime(first)[0] == 0
        # each newcomer took an unprotected flooder id's place: forgotten at the next housekeeping
        wait_until(lambda: server.log_so_far().count("evicted to make room for another client") >= 3, timeout=10,
                   what="the evicted ids forgotten")
        log = server.log_so_far()
        assert "limits.MAX_CLIENTS_PER_PEER" in log and "(limits.MAX_CLIENTS);" not in log
        first_id = next(line.split("client ", 1)[1].split()[0] for line in log.splitlines() if "connected" in line)
        # its own session answered for it: kept
        assert f"client {first_id} evicted" not in log and f"client {first_id} expired" not in log
        checks.undeclare()
        for token in tokens:
            token.undeclare()
        vrep.simxFinish(first)
    finally:
        flooder.close()
        server.stop()


def test_tokens_protect_at_most_max_per_peer_ids_of_one_session():
    sessions = Sessions(queue.SimpleQueue(), max_clients=4, max_per_peer=2, max_tokens=6)
    for client in "abcd":
        assert sessions.admit(client, "r", 1) is None
        sessions.take(sessions.get(client))
        assert sessions.token_seen(client)
    assert [sessions.token_verified(c, {"mallory"}) for c in "abc"] == [True, True, False]
    assert sessions.token_verified("d", {"mallory", "alice"})  # a wildcard answer cannot take alice's id
    assert sessions.tokens == {"a", "b", "d"} and sessions.unverified == {"c"}
    assert sessions.admit("e", "r", 1) is None and sessions.get("c") is None  # the unprotected one gave way
    assert sessions.admit("f", "r", 1) is not None  # every other slot is protected or pending
    sessions.token_gone("a")  # mallory's share has room again
    assert sessions.token_seen("g") and sessions.token_verified("g", {"mallory"})
    for client in "hij":
        sessions.token_seen(client)
    assert not sessions.token_seen("k")  # at most max_tokens recorded
