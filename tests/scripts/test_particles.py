"""Particle objects (sim.addParticleObject & co.) as force sources: a jet of respondable particles
pushes the free box it hits, a jet of particles that are not respondable pushes nothing, the
particles age out, and bad arguments are errors that name the call."""

from __future__ import annotations

import logging

import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco>
  <option timestep="0.005" gravity="0 0 0"/>
  <worldbody>
    <body name="Nozzle" pos="0 0 0"><geom type="box" size="0.02 0.02 0.02" contype="0" conaffinity="0"/></body>
    <body name="Box" pos="0.5 0 0"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.1"/></body>
  </worldbody>
  <custom><text name="simx:Nozzle" data="child_script=jet.lua"/></custom>
</mujoco>
"""
JET = """function sysCall_init()
  jet = sim.addParticleObject(%d, 0.01, 8500, {}, 0.5, 200)
end
function sysCall_actuation()
  for i = 1, 4 do sim.addParticleObjectItem(jet, {0.03, 0, 0, 4.03, 0, 0}) end  -- 4 m/s along +x
end
"""


def _box_x_after(tmp_path, options: int, steps: int = 60) -> float:
    (tmp_path / "scene.xml").write_text(SCENE)
    (tmp_path / "jet.lua").write_text(JET % options)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        sim.start()
        for _ in range(steps):
            sim.step()
        return float(sim.world.data.body("Box").xpos[0])
    finally:
        sim.close()


def test_respondable_particles_push_the_box_they_hit(tmp_path, caplog):
    caplog.set_level(logging.INFO, "simx.scripts")
    pushed = _box_x_after(tmp_path, 32 + 64 + 256)  # respondable, ignoring gravity
    assert pushed > 0.52, pushed  # 4 particles of 4.5 g at 4 m/s a step: the box moves away
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert any("particle objects" in r.getMessage() for r in caplog.records)


def test_particles_that_are_not_respondable_push_nothing(tmp_path):
    assert _box_x_after(tmp_path, 256) == pytest.approx(0.5)  # not respondable: they fly through


def test_bad_particle_calls_are_errors_naming_the_call(tmp_path, caplog):
    (tmp_path / "scene.xml").write_text(SCENE)
    (tmp_path / "jet.lua").write_text("""function sysCall_init() end
function bad_size() sim.addParticleObject(0, -1, 8500, {}, 1, 10) end
function bad_item() local h = sim.addParticleObject(0, 0.01, 8500, {}, 1, 10) sim.addParticleObjectItem(h, {1, 2}) end
function bad_handle() sim.removeParticleObject(12345) end
""")
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        sim.start()
        for function, text in (("bad_size", "size and density must be > 0"), ("bad_item", "needs 6 numbers"),
                               ("bad_handle", "no particle object 12345")):
            with pytest.raises(Exception, match=text):
                sim.scripts.call("Nozzle", 1, function, [], [], [], b"")
    finally:
        sim.close()
