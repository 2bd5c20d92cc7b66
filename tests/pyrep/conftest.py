"""Fixtures of the ``pyrep`` tests: a small MJCF scene written per test, launched in process."""

from __future__ import annotations

from pathlib import Path

import pytest

SCENE = """<mujoco model="pyrep_small">
  <compiler angle="radian"/>
  <option timestep="0.01"/>
  <worldbody>
    <light name="light" pos="0 0 3" dir="0 0 -1"/>
    <geom name="floor" type="plane" size="2 2 0.05" rgba="0.8 0.8 0.8 1"/>
    <body name="cube" pos="0.5 0 0.3">
      <freejoint/>
      <geom name="cube_geom" type="box" size="0.05 0.05 0.05" mass="0.5" rgba="1 0 0 1"/>
    </body>
    <body name="base" pos="-0.5 0 0.1">
      <geom type="cylinder" size="0.05 0.05" rgba="0 0 1 1"/>
      <body name="link" pos="0 0 0.1">
        <joint name="hinge" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom type="box" size="0.2 0.02 0.02" pos="0.2 0 0" mass="0.2"/>
        <site name="tip" pos="0.4 0 0"/>
      </body>
    </body>
    <site name="prox" pos="0.5 0 1.0" quat="0 1 0 0"/>
    <camera name="cam" pos="0 -1.5 0.8" xyaxes="1 0 0 0 0.5 1" resolution="32 24"/>
  </worldbody>
  <sensor>
    <rangefinder site="prox" cutoff="2"/>
  </sensor>
  <actuator>
    <velocity name="hinge_motor" joint="hinge" kv="2"/>
  </actuator>
</mujoco>
"""


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    path = tmp_path / "small.xml"
    path.write_text(SCENE)
    return path


@pytest.fixture
def pr(scene: Path):
    """A launched and started PyRep on the small scene; shut down after the test."""
    from pyrep import PyRep

    instance = PyRep()
    instance.launch(str(scene), headless=True)
    instance.start()
    yield instance
    instance.shutdown()
