"""The same ``pyrep`` against a running simx-server over ZMQ (``PyRep.connect``, the official
client): objects, stepping, images."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep import PyRep
from pyrep.objects import Joint, Shape, VisionSensor

pytest.importorskip("coppeliasim_zmqremoteapi_client")

try:
    from conftest import ServerProcess, free_port
except ImportError:
    from tests.conftest import ServerProcess, free_port


def test_pyrep_drives_a_server_over_zmq(pyrep_scene):
    port = free_port()
    server = ServerProcess(str(pyrep_scene), "--stopped", "--zmq-port", str(port))
    pr = PyRep()
    try:
        pr.connect("127.0.0.1", port)
        cube = Shape("cube")
        start = cube.get_position()
        assert isinstance(Joint("hinge"), Joint)
        pr.start()
        t0 = pr.get_simulation_timestep()
        for _ in range(10):
            pr.step()
        assert cube.get_position()[2] < start[2]  # the server stepped 10 times: it fell
        assert VisionSensor("cam").capture_rgb().shape == (24, 32, 3)
        assert t0 > 0
        pr.stop()
        assert np.allclose(cube.get_position(), start)
    finally:
        pr.shutdown()
        server.stop()
