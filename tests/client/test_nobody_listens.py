"""``simxStart`` with nobody listening says so once at Python's default log level (issue 33 item 3):
a legacy program that retries forever (robotControl.py: "Failed connecting to remote API
server!" every 5 s) shows the cause once, not never and not at every try."""

from __future__ import annotations

import os
import subprocess
import sys

from conftest import ROOT, free_port

PROGRAM = """
import vrep
for _ in range(3):
    assert vrep.simxStart("127.0.0.1", {port}, True, True, 200, 5) == -1
"""


def test_no_server_is_one_warning_at_the_default_log_level():
    port = free_port()
    env = {k: v for k, v in os.environ.items() if k not in ("SIMX_ZENOH_CONFIG", "ZENOH_CONFIG")}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    out = subprocess.run([sys.executable, "-c", PROGRAM.format(port=port)], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    said = [line for line in out.stderr.splitlines() if "no simx server" in line]
    assert len(said) == 1, out.stderr
    assert f"simxStart(127.0.0.1, {port}): no simx server at 127.0.0.1:{port}" in said[0]
