"""TLS, authentication and access control (issue 11, defects 12 and 13).

One ``simx-server`` for the module runs with ``docs/security/server.json5`` (TLS + user/password
+ access control for users alice and bob) as shipped: the folder docs/security is copied into a
temporary checkout root, ``sh docs/security/make-certs.sh docs/security/tls alice bob`` makes the
certificates where the configs name them, only the port is replaced, and the server and the
clients run from that root, as a user runs them from the checkout. The client configs are
``docs/security/client-alice.json5`` and ``client-bob.json5``; so these tests also check that
the documented files work as they are.

* Defect 12: an unchanged legacy program, configured only by ``SIMX_ZENOH_CONFIG``, connects
  over TLS and works; ``ZENOH_CONFIG`` works too; a client without credentials, with a wrong
  password or with an unreadable config file gets ``simxStart`` -1 within its timeout.
* Defect 13: bob, authenticated, attacks alice: he declares queryables on the call keys, puts
  forged stream updates on her stream key, and sends ``Bye`` under her id. With the secure
  setup none of it reaches her or the server, and she keeps working; against a server without
  access control the same attack succeeds (the control that shows the check can fail).
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import msgpack
import pytest
import zenoh

from conftest import ROOT, ServerProcess, free_port, wait_until
from simx_client import api, connect, connection
from simx_client import protocol as P
from simx_wire import proof as PR

DOCS = ROOT / "docs" / "security"
B, STREAMING, BUFFER = 0x010000, 0x020000, 0x030000  # simx_opmode_blocking, _streaming, _buffer
ROBOT = "UR5"


def install(name: str, root: Path, port: int, dest: Path | None = None, tutorial_port: int | None = None) -> Path:
    """A docs/security file as shipped, its port 19997 replaced by ``port`` and 19999 (the
    tutorial's) by ``tutorial_port`` (default: a free port), written into ``dest`` (default
    ``root``/docs/security): its relative paths (docs/security/tls/..., docs/security/users.txt)
    resolve from ``root``, the folder the server and the clients run in."""
    text = (DOCS / name).read_text().replace("19997", str(port))
    text = text.replace("19999", str(tutorial_port or free_port()))
    path = (dest or root / "docs" / "security") / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def secure(tmp_path_factory):
    """The secure server and its files: ``(server, {name: path})``."""
    if shutil.which("openssl") is None:
        pytest.skip("the certificates are made with the openssl command")
    root = tmp_path_factory.mktemp("secure")  # a checkout's root, as far as docs/security goes
    shutil.copytree(DOCS, root / "docs" / "security")
    subprocess.run(["sh", "docs/security/make-certs.sh", "docs/security/tls", "alice", "bob"], cwd=root,
                   check=True, capture_output=True, timeout=30)
    port, tutorial_port = free_port(), free_port()  # for 19997 and 19999
    files = {name: install(name, root, port, tutorial_port=tutorial_port)
             for name in ("server.json5", "users.txt", "client-alice.json5", "client-bob.json5")}
    server = ServerProcess("--zenoh-config", str(files["server.json5"]), "--stopped", ports=[port, tutorial_port],
                           cwd=root, renderers="on-demand")
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(root)  # the clients of this module read the configs' relative paths from there
        yield server, files
    server.stop()


@pytest.fixture
def env(monkeypatch):
    """The client's environment, cleared of any Zenoh config and user."""
    for var in ("SIMX_ZENOH_CONFIG", "ZENOH_CONFIG", "SIMX_USER"):
        monkeypatch.delenv(var, raising=False)
    return monkeypatch


def start(port: int, timeout_ms: int = 5000) -> int:
    return api.simxStart("127.0.0.1", port, True, True, timeout_ms, 5)


# ------------------------------------------------------------------ defect 12
def test_server_config_listens_where_asked_and_warns_beyond_loopback(tmp_path, caplog):
    from simx_server.legacy.zenoh_config import zenoh_config

    def listen(config: zenoh.Config):
        return json.loads(config.get_json("listen/endpoints"))

    auth_only = tmp_path / "auth.json5"  # TLS or authentication settings, no endpoints
    auth_only.write_text('{ scouting: { multicast: { enabled: true } }, queries_default_timeout: 1234 }')
    with caplog.at_level(logging.WARNING, logger="simx.server"):
        config = zenoh_config(["tcp/127.0.0.1:19997"], auth_only)
        assert listen(config) == ["tcp/127.0.0.1:19997"]  # not Zenoh's default, every interface
        assert json.loads(config.get_json("scouting/multicast/enabled")) is False
        assert json.loads(config.get_json("queries_default_timeout")) == 1234
        own = tmp_path / "own.json5"
        own.write_text('{ listen: { endpoints: ["tls/localhost:1", "tcp/[::1]:2"] } }')
        assert listen(zenoh_config(["tcp/127.0.0.1:19997"], own)) == ["tls/localhost:1", "tcp/[::1]:2"]
        assert caplog.text == ""
        zenoh_config(["tcp/127.0.0.1:1", "tcp/0.0.0.0:2"])
    assert "listening on tcp/0.0.0.0:2 without access control" in caplog.text
    caplog.clear()
    acl = tmp_path / "acl.json5"
    acl.write_text('{ listen: { endpoints: ["tls/192.0.2.1:1"] }, access_control: { enabled: true } }')
    with caplog.at_level(logging.WARNING, logger="simx.server"):
        assert listen(zenoh_config([], acl)) == ["tls/192.0.2.1:1"]
    assert caplog.text == ""


def test_client_config_keeps_the_file_and_forces_what_simxstart_asks_for(env, tmp_path):
    from simx_client.connection import client_config, client_id

    def setting(config: zenoh.Config, key: str):
        return json.loads(config.get_json(key))

    plain = client_config("127.0.0.1", 19997)  # no file: as before
    assert setting(plain, "connect/endpoints") == ["tcp/127.0.0.1:19997"]
    assert len(client_id(plain)) == 32 and P.valid_client_id(client_id(plain))

    file = tmp_path / "peer.json5"
    file.write_text("""{ mode: "peer", connect: { endpoints: { peer: ["tcp/10.0.0.1:1"], client: ["quic/localhost:7447"] } },
                        scouting: { multicast: { enabled: true } }, queries_default_timeout: 1234,
                        transport: { auth: { usrpwd: { user: "carol", password: "x" } } } }""")
    env.setenv("ZENOH_CONFIG", str(file))
    config = client_config("localhost", 5)
    assert setting(config, "mode") == "client"
    assert setting(config, "connect/endpoints") == ["quic/localhost:5"]  # its protocol, simxStart's address
    assert setting(config, "scouting/multicast/enabled") is False
    assert setting(config, "queries_default_timeout") == 1234  # the rest of the file stays
    assert client_id(config).startswith("carol-")
    env.setenv("SIMX_USER", "dave.2_B")  # wins over the file's user
    assert client_id(config).startswith("dave.2_B-") and len(client_id(config)) == 9 + 32
    env.setenv("SIMX_USER", "x" * 95)
    assert P.valid_client_id(client_id(config))
    env.setenv("SIMX_ZENOH_CONFIG", str(file).replace("peer", "nope"))  # wins over ZENOH_CONFIG
    with pytest.raises(P.LocalError, match=r"nope\.json5 \(\$SIMX_ZENOH_CONFIG\)"):
        client_config("localhost", 5)
    for user in ("a-b", "a/b", "x" * 96, "*", "@a", "a b"):
        env.setenv("SIMX_USER", user)
        with pytest.raises(P.LocalError, match="cannot start a client id"):
            client_id(config)


LEGACY_PROGRAM = """
import vrep
cid = vrep.simxStart('127.0.0.1', {port}, True, True, 5000, 5)
rc, handle = vrep.simxGetObjectHandle(cid, '{robot}', vrep.simx_opmode_blocking)
rc2, handles = vrep.simxGetObjects(cid, vrep.sim_handle_all, vrep.simx_opmode_blocking)
import simx_client.api
client = simx_client.api._connections[cid].client if cid >= 0 else None
vrep.simxFinish(cid)
print(cid, rc, handle, rc2, len(handles), client)
"""


def test_legacy_program_uses_tls_and_a_user_from_the_environment_alone(secure):
    server, files = secure
    assert f"listening on tls/127.0.0.1:{server.port}" in server.ready_line
    env = {k: v for k, v in os.environ.items() if k not in ("ZENOH_CONFIG", "SIMX_USER")}
    env["SIMX_ZENOH_CONFIG"] = str(files["client-alice.json5"])
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))  # import vrep
    root = files["client-alice.json5"].parents[2]  # the program runs from the root, as documented
    out = subprocess.run([sys.executable, "-c", LEGACY_PROGRAM.format(port=server.port, robot=ROBOT)],
                         env=env, cwd=root, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    cid, rc, handle, rc2, count, client = out.stdout.split()
    assert (int(cid), int(rc), int(rc2)) == (0, 0, 0)
    assert int(handle) >= 0 and int(count) > 10
    assert client.startswith("alice-") and P.valid_client_id(client)


def test_secure_config_serves_both_legacy_ports(secure, env):
    """Issue 33 item 3: server.json5 listens on 19997 and on 19999, the port of the tutorial's
    robotControl.py; the same client config reaches either (simxStart's port is used)."""
    server, files = secure
    port, tutorial_port = server.ports
    for shipped in ("server.json5", "server-mtls.json5"):
        text = (DOCS / shipped).read_text()
        assert '"tls/127.0.0.1:19997", "tls/127.0.0.1:19999"' in text, shipped
    assert f"tls/127.0.0.1:{port}" in server.ready_line and f"tls/127.0.0.1:{tutorial_port}" in server.ready_line
    env.setenv("SIMX_ZENOH_CONFIG", str(files["client-alice.json5"]))
    cid = start(tutorial_port)
    assert cid >= 0
    try:
        assert api._connections[cid].client.startswith("alice-")
        rc, handle = api.simxGetObjectHandle(cid, ROBOT, B)
        assert rc == 0 and handle >= 0
    finally:
        api.simxFinish(cid)


def test_zenoh_config_variable_and_refused_clients(secure, env, tmp_path, caplog):
    server, files = secure
    # Zenoh's own convention works as well.
    env.setenv("ZENOH_CONFIG", str(files["client-bob.json5"]))
    cid = start(server.port)
    try:
        assert cid >= 0
        assert api._connections[cid].client.startswith("bob-")
        assert api.simxGetObjectHandle(cid, ROBOT, B)[0] == 0
    finally:
        api.simxFinish(cid)
    env.delenv("ZENOH_CONFIG")

    bob = files["client-bob.json5"].read_text()
    anonymous = tmp_path / "anonymous.json5"  # TLS, but no user/password
    anonymous.write_text(bob.replace('auth: { usrpwd: { user: "bob", password: "change-this-bob-password" } },', ""))
    assert "usrpwd" not in anonymous.read_text()
    wrong = tmp_path / "wrong.json5"
    wrong.write_text(bob.replace("change-this-bob-password", "guess"))
    plain = tmp_path / "plain.json5"  # no TLS: a TCP client
    plain.write_text("{ mode: 'client', scouting: { multicast: { enabled: false } } }")
    where = f"127.0.0.1:{server.port}"
    causes = {  # one WARNING line naming the cause and the config file in play
        anonymous: f"the server at {where} refused the session: it requires authentication and this client "
                   "gives no user and password (transport/auth/usrpwd)",
        wrong: f"the server at {where} refused the session of user 'bob': a wrong password, or a user it does "
               "not know (transport/auth/usrpwd)",
        plain: f"the server at {where} speaks TLS and this client connects over plain TCP",
    }
    # A refusal ends simxStart at its first attempt: waiting would not change the server's
    # answer. Stated as attempts (Connection objects made), not seconds: a client that retried
    # until its timeout would make several.
    attempts = []

    class Counted(connection.Connection):
        def __init__(self, *args, **kwargs):
            attempts.append(1)
            super().__init__(*args, **kwargs)

    env.setattr(connect, "Connection", Counted)  # what simxStart (connect.wait_connect) makes
    for config, cause in causes.items():
        env.setenv("SIMX_ZENOH_CONFIG", str(config))
        caplog.clear()
        attempts.clear()
        with caplog.at_level(logging.WARNING, logger="simx.client"):
            assert start(server.port, timeout_ms=1000) == -1, config.name
        assert len(attempts) == 1, (config.name, len(attempts))
        refusals = [r for r in caplog.records if r.levelno == logging.WARNING]
        assert len(refusals) == 1, caplog.text
        assert cause in refusals[0].getMessage() and f"{config} ($SIMX_ZENOH_CONFIG)" in refusals[0].getMessage()
    # nobody listening stays what it is: no refusal is claimed
    env.setenv("SIMX_ZENOH_CONFIG", str(files["client-bob.json5"]))
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="simx.client"):
        assert start(free_port(), timeout_ms=300) == -1
    assert "no simx server" in caplog.text and "refused" not in caplog.text

    # A config that cannot be used, or a user name that cannot start an id: -1 at once, and why.
    env.setenv("SIMX_ZENOH_CONFIG", str(tmp_path / "missing.json5"))
    attempts.clear()
    with caplog.at_level(logging.ERROR, logger="simx.client"):
        assert start(server.port) == -1
    assert len(attempts) == 1  # not retried until the timeout
    assert "missing.json5 ($SIMX_ZENOH_CONFIG)" in caplog.text
    env.setenv("SIMX_ZENOH_CONFIG", str(files["client-bob.json5"]))
    env.setenv("SIMX_USER", "bo/b-x")
    assert start(server.port) == -1
    assert "user name 'bo/b-x' cannot start a client id" in caplog.text


def test_mutual_tls_binds_the_certificate_name_to_the_client_ids(secure, env, tmp_path, caplog):
    root = secure[1]["server.json5"].parents[2]  # its certificates: ca, server, alice, bob
    port = free_port()
    config = install("server-mtls.json5", root, port, tmp_path)
    alice = install("client-mtls-alice.json5", root, port, tmp_path)
    server = ServerProcess("--zenoh-config", str(config), "--stopped", ports=[port], cwd=root, renderers="on-demand")
    try:
        env.setenv("SIMX_ZENOH_CONFIG", str(alice))
        env.setenv("SIMX_USER", "alice")
        cid = start(port)
        assert cid >= 0
        try:
            assert api._connections[cid].client.startswith("alice-")
            assert api.simxGetObjectHandle(cid, ROBOT, B)[0] == 0
        finally:
            api.simxFinish(cid)
        env.setenv("SIMX_USER", "bob")  # alice's certificate, bob's ids: every call is refused
        with caplog.at_level(logging.WARNING, logger="simx.client"):
            assert start(port, timeout_ms=1000) == -1
        assert "its access control does not let user bob call under its ids" in caplog.text
        env.setenv("SIMX_ZENOH_CONFIG", str(install("client-alice.json5", root, port, tmp_path)))
        env.delenv("SIMX_USER")  # TLS and a password, but no client certificate
        assert start(port, timeout_ms=1000) == -1
    finally:
        server.stop()


# ------------------------------------------------------------------ defect 13
FORGED = 987654


def attack(victim_id: str, attacker: zenoh.Config, witness: zenoh.Config, reads, bye_timeout: float = 0.5,
           update_wait: float = 0.2) -> dict:
    """Bob's attacks on alice (``victim_id``); returns what each achieved.

    ``reads()`` makes 20 of alice's blocking reads and returns their values; ``witness`` is a
    second session of alice's that watches her stream key; ``bye_timeout`` (s): how long Bob's
    Bye waits for an answer (a refused query is never answered: the secured case waits it out);
    ``update_wait`` (s): how long the witness may take to see a forwarded update after the
    barriers (its subscriber runs on another Zenoh thread than the barrier's reply)."""
    forged_reply = P.response(0, 0, [[True, FORGED]])
    forged_update = P.stream_update(0, [["GetObjectHandle", [ROBOT], True, FORGED]])
    seen: list[bytes] = []
    with zenoh.open(attacker) as bob, zenoh.open(witness) as watch:
        bob_id, witness_id = f"bob-{os.urandom(16).hex()}", f"alice-{os.urandom(16).hex()}"
        me = P.call_key(P.DEFAULT_PREFIX, bob_id)

        def barrier(session: zenoh.Session, client: str) -> None:
            """A round trip through the server: what the session sent before has been handled."""
            replies = list(session.get(P.call_key(P.DEFAULT_PREFIX, client), timeout=5.0,
                                       payload=P.request(client, [["Hello", B, []]])))
            assert any(r.ok is not None for r in replies), "the server did not answer"

        # (a) queryables that answer the victim's calls with forged values
        lock = threading.Lock()
        answered = []

        def forge(query: zenoh.Query) -> None:
            if str(query.key_expr) != me:
                with lock:
                    answered.append(str(query.key_expr))
                query.reply(query.key_expr, forged_reply)

        q1 = bob.declare_queryable("simx/call/**", forge)
        q2 = bob.declare_queryable(P.call_key(P.DEFAULT_PREFIX, victim_id), forge)
        barrier(bob, bob_id)
        values = reads()
        q1.undeclare()
        q2.undeclare()

        # (b) a forged stream update on the victim's stream key
        sub = watch.declare_subscriber(P.stream_key(P.DEFAULT_PREFIX, victim_id),
                                       lambda s: seen.append(s.payload.to_bytes()))
        barrier(watch, witness_id)  # the subscription is in place
        bob.put(P.stream_key(P.DEFAULT_PREFIX, victim_id), forged_update)
        barrier(bob, bob_id)  # the server has handled the put ...
        barrier(watch, witness_id)  # ... and anything it forwarded has reached the witness
        deadline = time.monotonic() + update_wait
        while forged_update not in seen and time.monotonic() < deadline:
            time.sleep(0.01)
        forged_seen = forged_update in seen
        sub.undeclare()
        server_seen = any(r.ok is not None for r in watch.liveliness().get(P.server_token_key(), timeout=5.0))

        # (c) Bye under the victim's id
        replies = list(bob.get(P.call_key(P.DEFAULT_PREFIX, victim_id), timeout=bye_timeout,
                               payload=P.request(victim_id, [["Bye", 0, []]])))
        bye_answered = any(r.ok is not None for r in replies)
        bye_refused = any(r.ok is not None and type(m := msgpack.unpackb(r.ok.payload.to_bytes())) is dict
                          and str(m.get("err", "")).startswith(PR.NOT_YOURS) for r in replies)
    return {"forged reads": sum(v == FORGED for v in values), "reads": values,
            "queries seen by the attacker": len(answered), "forged update delivered": forged_seen,
            "Bye answered": bye_answered, "Bye refused": bye_refused, "server token seen": server_seen}


def test_access_control_keeps_other_users_out(secure, env):
    server, files = secure
    env.setenv("SIMX_ZENOH_CONFIG", str(files["client-alice.json5"]))
    cid = start(server.port)
    assert cid >= 0
    try:
        victim = api._connections[cid].client
        assert victim.startswith("alice-")
        handle = api.simxGetObjectHandle(cid, ROBOT, B)[1]

        def reads() -> list:
            return [api.simxGetObjectHandle(cid, ROBOT, B)[1] for _ in range(20)]

        bob = zenoh.Config.from_file(str(files["client-bob.json5"]))
        alice = zenoh.Config.from_file(str(files["client-alice.json5"]))
        got = attack(victim, bob, alice, reads)
        assert got == {"forged reads": 0, "reads": [handle] * 20, "queries seen by the attacker": 0,
                       "forged update delivered": False, "Bye answered": False, "Bye refused": False,
                       "server token seen": True}
        # alice still works, streams included.
        assert api.simxGetObjectHandle(cid, ROBOT, STREAMING)[0] in (0, 1)
        wait_until(lambda: api.simxGetObjectHandle(cid, ROBOT, BUFFER) == (0, handle),
                   what="alice's stream update")
    finally:
        api.simxFinish(cid)


def plain_config(port: int) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


@pytest.fixture(scope="module")
def plain_server():
    """A server as it runs by default: plain TCP on loopback, no authentication, no access control."""
    server = ServerProcess("--stopped", renderers="on-demand")
    yield server
    server.stop()


def test_without_access_control_the_same_attack_succeeds(plain_server, env):
    """The control: on a plain server bob sees alice's calls and forges her stream; his Bye under
    her id is answered, but refused: her requests carry the proof of her secret, his cannot
    (tests/transport/test_client_identity.py)."""
    cid = start(plain_server.port)
    assert cid >= 0
    try:
        victim = api._connections[cid].client

        def reads() -> list:
            return [api.simxGetObjectHandle(cid, ROBOT, B)[1] for _ in range(20)]

        got = attack(victim, plain_config(plain_server.port), plain_config(plain_server.port), reads,
                     bye_timeout=5.0, update_wait=5.0)  # answered: each ends at the answer; 0.5 s was too short under load
    finally:
        api.simxFinish(cid)
    assert got["forged reads"] > 0 and got["queries seen by the attacker"] > 0
    assert got["forged update delivered"] and got["Bye answered"] and got["Bye refused"]


def test_a_wildcard_client_id_is_refused(plain_server, env):
    """A request under the id ``*`` (on the key ``simx/call/*``) would have the server publish
    that client's streams on ``simx/stream/*``: to every client. Every server refuses it."""
    with zenoh.open(plain_config(plain_server.port)) as session:
        for client in ("*", "**", "a$*"):
            replies = list(session.get(P.call_key(P.DEFAULT_PREFIX, client), timeout=5.0,
                                       payload=P.request(client, [["GetObjectHandle", STREAMING, [ROBOT]]])))
            assert len(replies) == 1 and replies[0].ok is not None
            # (``**`` also reaches the old-version refusal on ``simx/call``: a refusal too.)
            with pytest.raises(P.ProtocolError, match=r"invalid client id|version mismatch"):
                P.unpack_response(replies[0].ok.payload.to_bytes())


def test_viewers_watch_and_only_the_server_feeds_them(secure, env):
    """simx-viewer through the access control (issue 14): alice gets the model and the states;
    bob can neither answer the model query nor put a forged state on the viewers' key."""
    from simx_viewer import ViewerLink

    server, files = secure
    env.setenv("SIMX_ZENOH_CONFIG", str(files["client-alice.json5"]))
    forged_model = P.viewer_model(999, "0", b"forged", P.viewer_state(999, 0.0, b"", b"", b"", b""))
    forged_state = P.viewer_state(999, 0.0, b"", b"", b"", b"")
    cid = start(server.port)
    assert cid >= 0
    bob = zenoh.open(zenoh.Config.from_file(str(files["client-bob.json5"])))
    try:
        with ViewerLink("127.0.0.1", server.port) as link:
            first = link.fetch_model()
            assert first.model.nbody > 1
            seen: list[bytes] = []  # a second subscriber of alice's: states put from now on
            sub = link.session.declare_subscriber(P.viewer_state_key(), lambda s: seen.append(s.payload.to_bytes()))
            queryable = bob.declare_queryable(P.viewer_model_key(), lambda q: q.reply(q.key_expr, forged_model))
            for _ in range(5):
                bob.put(P.viewer_state_key(), forged_state)
            joint = api.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
            assert api.simxSetJointPosition(cid, joint, 0.5, B) == 0  # stopped: the next idle tick shows it
            wait_until(lambda: seen, what="the server's state after the joint moved")
            assert forged_state not in seen and P.unpack_viewer_state(seen[-1])[1] == first.generation
            assert all(link.fetch_model().generation == first.generation for _ in range(3))
            queryable.undeclare()
            sub.undeclare()
    finally:
        bob.close()
        api.simxFinish(cid)
