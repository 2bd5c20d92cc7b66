"""Deferred loads of V-REP files (simx_server.scene.conversions), in-process: the load command
answers a Deferred at once, the conversion runs in the worker on a thread of its own, and the
load happens only when the job it hands over (``sim.post``) runs on the simulation thread,
here the test's thread, as the loop would run it."""

from __future__ import annotations

import queue
import threading

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


def test_each_client_has_its_share_of_the_conversion_queue_served_round_robin(sim, monkeypatch):
    """Five clients' slow files filled the server-wide queue (4 waiting) and another client's
    small file was answered busy meanwhile (issue 48). Now each client has
    MAX_WAITING_PER_CLIENT loads converted or waiting: its next is busy, naming the share, and a
    newcomer's load is taken; the worker takes them round robin, one per client in turn, so the
    newcomer's comes before any client's third."""
    real, gate, started, order = conversions.ttt_cache.mjcf_for, threading.Event(), threading.Event(), []

    def held(file, root, client=False):  # the first conversion takes as long as the test wants
        order.append(file.name)
        if len(order) == 1:
            started.set()
            assert gate.wait(60)
        return real(file, root, client=client)

    monkeypatch.setattr(conversions.ttt_cache, "mjcf_for", held)
    files = sim.editor.files
    share = conversions.MAX_WAITING_PER_CLIENT
    crate = (files.roots[0] / "crate.ttm").read_bytes()
    deferred = []
    for c in ("a", "b", "c", "d", "e"):
        with files.acting(f"legacy:{c}"):
            for j in range(share):
                (files.roots[0] / f"{c}{j}.ttm").write_bytes(crate)
                deferred.append(H["LoadModel"](sim, [f"{c}{j}.ttm", 0]))
                if len(deferred) == 1:  # a0 under way before the others wait (a loaded machine's worker
                    assert started.wait(60)  # could take b0 first: a's next turn comes after e)
            with pytest.raises(RemoteError, match=f"server busy: .*MAX_WAITING_PER_CLIENT = {share}"):
                H["LoadModel"](sim, ["box.ttt", 0])  # one more, while its share waits
    assert conversions.pending() == 5 * share
    (files.roots[0] / "new.ttm").write_bytes(crate)
    with files.acting("legacy:newcomer"):
        deferred.append(H["LoadModel"](sim, ["new.ttm", 0]))  # before: busy
    gate.set()
    for _ in deferred:
        sim.jobs.get(timeout=60)()  # posted in the order converted
    assert all(d.future.result(timeout=0) is not None for d in deferred)
    # a0 was under way; then one of each client in turn (a again first, being first in the ring)
    assert order[:8] == ["a0.ttm", "a1.ttm", "b0.ttm", "c0.ttm", "d0.ttm", "e0.ttm", "new.ttm", "a2.ttm"]
    assert sorted(order) == sorted([f"{c}{j}.ttm" for c in "abcde" for j in range(share)] + ["new.ttm"])
    assert conversions.pending() == 0


def test_without_a_loop_the_load_waits_for_the_worker(sim):
    sim.post = None
    assert H["LoadScene"](sim, ["box.ttt", 0]) is None
    assert "Box" in sim.world.by_name
