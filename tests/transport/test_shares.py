"""Shares of the server's shared limits, on a real server (issue 48): a client's loads of V-REP
files take at most ``scene.conversions.MAX_WAITING_PER_CLIENT`` places of the conversion queue
(its next is "server busy" naming that share, another client's load is taken meanwhile), and
``simxTransferFile`` is written off the simulation thread, its reply leaving once written.
tests/scene/ttt/test_ttt_deferred.py and tests/scene/test_client_files.py have the shares'
arithmetic in process, with small bounds."""

from __future__ import annotations

import importlib.util
import tempfile
import threading
from pathlib import Path

import pytest

import vrep
from conftest import ServerProcess, free_port
from simx_client import api
from simx_server.scene import conversions
from simx_wire import protocol as P

pytestmark = pytest.mark.renderers_on_demand
B, ONESHOT = vrep.simx_opmode_blocking, vrep.simx_opmode_oneshot
_spec = importlib.util.spec_from_file_location("tttwriter", Path(__file__).parents[1] / "scene" / "ttt" / "tttwriter.py")
W = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(W)


def test_one_clients_loads_take_its_share_of_the_conversion_queue_and_transfers_are_written(tmp_path):
    model = tmp_path / "crate.ttm"
    model.write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5))))
    srv = ServerProcess("--stopped", ports=[free_port(), free_port()], renderers="on-demand")
    a = vrep.simxStart("127.0.0.1", srv.ports[0], True, True, 5000, 5)
    b = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 5000, 5)
    try:
        assert a >= 0 and b >= 0
        share = conversions.MAX_WAITING_PER_CLIENT
        for cid, names in ((a, [f"m{i}.ttm" for i in range(share + 1)]), (b, ("b.ttm",))):
            for name in names:  # written off the simulation thread; the reply once written
                assert vrep.simxTransferFile(cid, str(model), name, 5, B) == 0
        folder = next(Path(tempfile.gettempdir()).glob(f"simx-{srv.proc.pid}-*"))
        assert len(list(folder.glob(".simx-clients/*/*.ttm"))) == share + 2
        # a's loads in one request: the first is converted (a worker process), the others wait,
        # and the last, executed microseconds later, finds a's share taken.
        got: list = []
        loads = [["LoadModel", ONESHOT, [f"m{i}.ttm", 1]] for i in range(share + 1)]
        first = threading.Thread(target=lambda: got.append(api._connections[a].request(loads, timeout=120)))
        first.start()
        ((ok, handle),) = api._connections[b].request([["LoadModel", B, ["b.ttm", 1]]], timeout=120)
        first.join(120)
        assert ok is True and type(handle) is int, handle  # b's load is not busy
        *done, (ok, why) = got[0]
        assert [(ok, type(h)) for ok, h in done] == [(True, int)] * share
        assert ok is False and why.startswith(f"simxLoadModel: {P.BUSY}"), why
        assert f"MAX_WAITING_PER_CLIENT = {share}" in why
        again = [["LoadModel", B, [f"m{share}.ttm", 1]]]
        assert api._connections[a].request(again, timeout=120)[0][0] is True  # its share is back
    finally:
        vrep.simxFinish(a)
        vrep.simxFinish(b)
        log = srv.stop()
    assert "Traceback" not in log
