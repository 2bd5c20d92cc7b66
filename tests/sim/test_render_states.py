"""A render thread's copies of the world's state (RenderThread.state): frames show the state
they were asked for, whether the copy is new or filled again, and a few copies serve a
simulation that goes on step after step."""

from __future__ import annotations

import os
import threading

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402
from simx_server.sim.render_thread import STATE_COPIES  # noqa: E402

# A box that slides along x under a camera looking down: each position, another depth frame.
SCENE = """
<mujoco>
  <visual><quality offsamples="0"/></visual>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="box" pos="0 0 0.2">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.15 0.15 0.15"/>
    </body>
    <camera name="eye" pos="0 0 2" resolution="64 48" fovy="80"/>
  </worldbody>
  <custom><text name="simx:eye" data="near=0.05 far=3 image=depth"/></custom>
</mujoco>
"""
POSITIONS = [-0.6, -0.3, 0.0, 0.3, 0.6, 0.45, -0.45]


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "slide.xml"
    path.write_text(SCENE)
    s = Simulation(path, dt=0.05, realtime=False)
    yield s
    s.close()


def move(sim: Simulation, x: float) -> None:
    sim.world.data.qpos[0] = x
    sim.world.changed()


def reference(sim: Simulation) -> list[np.ndarray]:
    """Each position's depth frame, asked for and waited for one at a time."""
    eye = sim.world.resolve("eye").handle
    frames = []
    for x in POSITIONS:
        move(sim, x)
        frames.append(sim.vision._frame(eye, "depth").result())
    return frames


def test_frames_queued_behind_a_busy_thread_show_their_own_state(sim):
    expected = reference(sim)
    assert all(not np.array_equal(a, b) for a, b in zip(expected, expected[1:]))
    eye, thread = sim.world.resolve("eye").handle, sim.vision._thread
    gate = threading.Event()
    thread.executor.submit(gate.wait, 10)  # every frame below queues behind it
    futures = []
    for x in POSITIONS:  # more states than copies kept: every copy is still to be read
        move(sim, x)
        futures.append(sim.vision._frame(eye, "depth"))
    assert not any(f.done() for f in futures)
    gate.set()
    for future, frame in zip(futures, expected):
        assert np.array_equal(future.result(), frame)


def test_copies_are_filled_again_once_read(sim):
    expected = reference(sim)
    eye, thread = sim.world.resolve("eye").handle, sim.vision._thread
    used = []  # the copies themselves (kept alive: their ids stay unique)
    for _ in range(3):
        for x, frame in zip(POSITIONS, expected):
            move(sim, x)
            future = sim.vision._frame(eye, "depth")
            used.append(thread.snapshot[2])
            assert np.array_equal(future.result(), frame)
    # 21 states drawn one after another, from at most STATE_COPIES copies
    assert len({id(c) for c in used}) <= STATE_COPIES and len(thread._copies) <= STATE_COPIES
