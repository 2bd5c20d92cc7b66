"""Issue 23 part 3's soak below simx: a bare Zenoh echo's RSS over connect / 30 requests / close.

``python -m benchmarks.zenoh_echo_soak MODE N REPLY_BYTES`` starts :mod:`benchmarks.zenoh_echo`
(the server's own Zenoh config) and makes ``N`` connections, each a fresh Zenoh session that
sends 30 queries for replies of ``REPLY_BYTES`` and closes: ``inproc`` in this process,
``proc`` one process per connection, ``killed`` one process per connection that exits without
closing its session. Prints the echo's RSS before and after every fifth of the connections.
Bounded by ``N`` (a few hundred at most); loopback only.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import zenoh

from benchmarks.zenoh_echo import KEY_DIRECT, make_request
from simx_client.connection import client_config

ROOT = Path(__file__).resolve().parents[1]
CHILD = """
import os, sys, zenoh
from simx_client.connection import client_config
s = zenoh.open(client_config("127.0.0.1", {port}))
for _ in range(30):
    for r in s.get({key!r}, payload=bytes.fromhex({req!r}), timeout=5):
        pass
os._exit(0) if {killed} else s.close()
"""


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024


def main(argv: list[str]) -> int:
    mode, n, size = argv[0], int(argv[1]), int(argv[2])
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    echo = subprocess.Popen([sys.executable, "-m", "benchmarks.zenoh_echo", "--port", str(port)], cwd=ROOT,
                            stdout=subprocess.PIPE, text=True)
    echo.stdout.readline()  # "echo ready"
    req = make_request(size, 200)
    child = CHILD.format(port=port, key=KEY_DIRECT, req=req.hex(), killed=mode == "killed")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        start, marks = _rss_mb(echo.pid), []
        for i in range(n):
            if mode == "inproc":
                session = zenoh.open(client_config("127.0.0.1", port))
                for _ in range(30):
                    for _reply in session.get(KEY_DIRECT, payload=req, timeout=5):
                        pass
                session.close()
            else:
                subprocess.run([sys.executable, "-c", child], check=True, env=env)
            if (i + 1) % max(1, n // 5) == 0:
                marks.append(f"{i + 1}: {_rss_mb(echo.pid):.0f}")
        print(f"{mode}, {n} connections, replies of {size} B: echo RSS {start:.0f} MB -> " + ", ".join(marks) + " MB")
    finally:
        echo.terminate()
        echo.wait()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
