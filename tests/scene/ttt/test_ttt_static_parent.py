"""A part on a joint whose parent is a static shape (RLBench's drawers in their cabinet, issue
58: open_drawer's demo pulled the handle and the drawer did not open). The drawer's side touches
the cabinet's wall within 10 um, the contact's normal across the slide: in MuJoCo's joint
coordinates that contact cannot be resolved and its friction pyramid braked the joint (a pull
of a few newtons moved it millimetres). The converter leaves out the contacts between a jointed
body and the static body its joint hangs from (MuJoCo's parent filter, which MuJoCo skips for a
parent fixed to the world), and a passive joint keeps a small dry friction for them: the drawer
slides under a light pull and stays put under its own weight with its axis a hair off level."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

TILT = 3.5e-4  # rad: the slide's axis goes this much downhill (RLBench's drawers: 3.4e-4)


def _cabinet() -> bytes:
    """A static wall (x in [-0.02, 0]), a passive slide along +y tilted down by TILT, and a
    0.34 kg drawer whose side overlaps the wall's face by 10 um, at the slide's lower limit."""
    # the joint's z axis: +y, turned down by TILT (a turn of -90 deg - TILT about x)
    a = -(math.pi / 2 + TILT) / 2
    quat = (math.cos(a), math.sin(a), 0.0, 0.0)
    return (W.cuboid_shape(1, -1, "Wall", (0.02, 0.5, 0.3), (-0.01, 0, 0.5), dynamic=False)
            + W.joint(2, 1, "Slide", (0.01, 0, 0), quat=quat, kind=11, motor=False, loop=False,
                      limits=(0.0, 0.3), max_force=100.0)
            + W.cuboid_shape(3, 2, "Drawer", (0.2, 0.2, 0.05), (0.1 - 1e-5, 0, 0), mass=0.34))


@pytest.fixture
def cabinet(tmp_path):
    f = tmp_path / "cabinet.ttt"
    f.write_bytes(W.ttt_file(W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + _cabinet()))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "cabinet")
    sim = Simulation(xml, realtime=False)
    sim.start()
    api = script_sim(sim.world, sim.world.resolve("Wall").handle, sim.signals, simulation=sim)
    yield sim, api
    sim.close()


def test_the_drawer_slides_under_a_light_pull_and_rests_otherwise(cabinet):
    sim, api = cabinet
    m = sim.world.model
    wall, drawer = m.body("Wall").id, m.body("Drawer").id
    assert any({int(b1), int(b2)} == {wall, drawer} for b1, b2 in zip(*divmod(m.exclude_signature, 1 << 16)))
    slide, body = api.getObject("/Slide"), api.getObject("/Drawer")
    dof = m.jnt_dofadr[m.joint("Slide").id]
    assert 0 < m.dof_frictionloss[dof] < 0.05  # N: 1% of mu * m * g
    for _ in range(40):  # 2 s at rest
        sim.step()
    assert api.getJointPosition(slide) < 1e-3  # no creep down its 0.02-degree slope
    axis = np.array(api.getObjectMatrix(slide, -1)).reshape(3, 4)[:, 2]
    for _ in range(10):  # 0.5 s of a 1 N pull along the slide
        api.addForce(body, [0, 0, 0], (1.0 * axis).tolist())
        sim.step()
    assert api.getJointPosition(slide) > 0.1  # about 2.8 m/s^2: to its 0.3 m limit
