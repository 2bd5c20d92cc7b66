"""Deferred loads of V-REP files (simx_server.scene.conversions), in-process: the load command
answers a Deferred at once, the conversion runs in the worker on a thread of its own, and the
load happens only when the job it hands over (``sim.post``) runs on the simulation thread,
here the test's thread, as the loop would run it."""

from __future__ import annotations

import queue

import pytest

from simx_client.protocol import RemoteError
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.scene import conversions
from simx_server.scene.simulation import Simulation
from simx_server.sim.vision_results import Deferred

try:
    from . import tttwriter as W
except ImportError:
    import tttwriter as W


@pytest.fixture
def sim(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "start.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), dynamic=False)))
    (folder / "box.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Box", (0.1, 0.1, 0.1), (0, 0, 1))))
    (folder / "crate.ttm").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5))))
    (folder / "chain.ttt").write_bytes(W.ttt_file(W.dummy(1, -1, "D1") + b"".join(
        W.dummy(k, k - 1, f"D{k}") for k in range(2, 300))))
    s = Simulation(folder / "start.ttt", dt=0.05, realtime=False, renderers_at_load=False)
    jobs: queue.SimpleQueue = queue.SimpleQueue()
    s.post = jobs.put
    s.jobs = jobs
    yield s
    s.close()


def _run_posted(sim, deferred: Deferred):
    """Run the job the conversion hands over (as the loop does), then the Deferred's value."""
    sim.jobs.get(timeout=60)()
    return deferred.future.result(timeout=0)


def test_a_scene_load_answers_at_once_and_loads_when_its_job_runs(sim):
    deferred = H["LoadScene"](sim, ["box.ttt", 0])
    assert type(deferred) is Deferred
    assert "Floor" in sim.world.by_name and "Box" not in sim.world.by_name  # not loaded yet
    assert _run_posted(sim, deferred) is None
    assert "Box" in sim.world.by_name and "Floor" not in sim.world.by_name


def test_a_model_load_answers_its_handle_once_loaded(sim):
    deferred = H["LoadModel"](sim, ["crate.ttm", 0])
    assert type(deferred) is Deferred
    handle = _run_posted(sim, deferred)
    assert sim.world.resolve("Crate").handle == handle


def test_a_file_past_a_bound_fails_its_deferred_with_the_bound(sim):
    deferred = H["LoadScene"](sim, ["chain.ttt", 0])
    with pytest.raises(RemoteError, match="chain.ttt: record DMY: .*more than MAX_TREE_DEPTH = 200"):
        deferred.future.result(timeout=60)
    assert sim.jobs.empty() and "Floor" in sim.world.by_name  # nothing handed over, nothing changed


def test_a_simulation_started_meanwhile_refuses_the_load(sim):
    deferred = H["LoadScene"](sim, ["box.ttt", 0])
    sim.start()
    with pytest.raises(RemoteError, match="stop the simulation first"):
        _run_posted(sim, deferred)
    sim.stop()
    assert "Floor" in sim.world.by_name


def test_loads_past_the_waiting_bound_are_answered_busy(sim, monkeypatch):
    monkeypatch.setattr(conversions, "_pending", [conversions.MAX_WAITING + 1])
    with pytest.raises(RemoteError, match="server busy: .*MAX_WAITING = 4"):
        H["LoadScene"](sim, ["box.ttt", 0])


def test_without_a_loop_the_load_waits_for_the_worker(sim):
    sim.post = None
    assert H["LoadScene"](sim, ["box.ttt", 0]) is None
    assert "Box" in sim.world.by_name
