"""Authentication covers the ZMQ listener too (issue 29, part 2): with the shipped Zenoh security
configuration (docs/security/server.json5: TLS, passwords, access control) the ZMQ remote API is
off unless the operator turns it on, and ``--zmq-curve`` lets in only the authorised CURVE keys."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import cbor2
import pytest
import zmq
import zmq.auth

from conftest import ROOT, ServerProcess, free_port, ready_line
from simx_server.zmq import codec

DOCS = ROOT / "docs" / "security"


@pytest.fixture(scope="module")
def secure_root(tmp_path_factory):
    """A checkout's root as far as docs/security goes, with its certificates made."""
    if shutil.which("openssl") is None:
        pytest.skip("the certificates are made with the openssl command")
    root = tmp_path_factory.mktemp("secure-zmq")
    shutil.copytree(DOCS, root / "docs" / "security")
    subprocess.run(["sh", "docs/security/make-certs.sh", "docs/security/tls", "alice", "bob"], cwd=root,
                   check=True, capture_output=True, timeout=30)
    return root


def _config(root: Path, port: int) -> Path:
    path = root / "docs" / "security" / f"server-{port}.json5"
    # as shipped, its ports replaced: 19997 by ``port``, 19999 (where a version lists it) by a free one
    path.write_text((DOCS / "server.json5").read_text().replace("19997", str(port)).replace("19999", str(free_port())))
    return path


def test_the_shipped_security_config_leaves_zmq_off(secure_root):
    """No ZMQ flag: the ready line says the ZMQ remote API is off, and why (the default port is
    never bound); --zmq-port alone is refused before anything loads."""
    port = free_port()
    config = _config(secure_root, port)
    proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", "--zenoh-config", str(config), "--stopped",
                             "--port", str(port)], cwd=secure_root, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = ready_line(proc, 60)
        assert line is not None and "no ZMQ remote API (--zenoh-config" in line, line
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=20)
    assert "serve it with --zmq-curve DIR" in err, err[-2000:]
    refused = subprocess.run([sys.executable, "-m", "simx_server.cli", "--zenoh-config", str(config),
                              "--zmq-port", str(free_port())], cwd=secure_root, capture_output=True, text=True,
                             timeout=60)
    assert refused.returncode == 2 and "add --zmq-curve DIR" in refused.stderr, refused.stderr


def _request(sock: zmq.Socket) -> dict | None:
    sock.send(codec.encode_request("sim.getSimulationState", [], "curve-test"))
    try:
        return cbor2.loads(sock.recv())
    except zmq.Again:
        return None


def test_curve_lets_in_only_authorised_keys(secure_root, tmp_path):
    """--zmq-curve beside the shipped config: a client with an authorised key pair is served; one
    without CURVE, or with a key pair of its own, gets nothing (its handshake is refused)."""
    keys = tmp_path / "zmq-keys"
    (keys / "clients").mkdir(parents=True)
    zmq.auth.create_certificates(keys, "server")
    zmq.auth.create_certificates(tmp_path, "alice")  # the client keeps its secret key
    shutil.copy(tmp_path / "alice.key", keys / "clients")
    zmq.auth.create_certificates(tmp_path, "mallory")  # a key pair nobody authorised
    port, zmq_port = free_port(), free_port()
    server = ServerProcess("--zenoh-config", str(_config(secure_root, port)), "--stopped", "--zmq-port",
                           str(zmq_port), "--zmq-curve", str(keys), ports=[port], cwd=secure_root,
                           renderers="on-demand")
    server_public, _ = zmq.auth.load_certificate(keys / "server.key")
    ctx = zmq.Context()
    try:
        def client(name: str | None) -> zmq.Socket:
            sock = ctx.socket(zmq.REQ)
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.RCVTIMEO, 20000 if name == "alice" else 1500)
            if name is not None:
                public, secret = zmq.auth.load_certificate(tmp_path / f"{name}.key_secret")
                sock.curve_publickey, sock.curve_secretkey, sock.curve_serverkey = public, secret, server_public
            sock.connect(f"tcp://127.0.0.1:{zmq_port}")
            return sock

        assert _request(client("alice")) == {"ret": [0]}
        assert _request(client(None)) is None
        assert _request(client("mallory")) is None
        assert _request(client("alice")) == {"ret": [0]}  # still served
    finally:
        ctx.destroy(0)
        log = server.stop()
    assert "its CURVE key is not an authorised client's" in log, log[-3000:]
    assert "Traceback" not in log
