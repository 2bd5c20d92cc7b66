"""Two shapes in contact have Bullet 2.78's friction, the product of their coefficients (capped at
10: ``btManifoldResult::calculateCombinedFriction``), as V-REP and CoppeliaSim 4.1 give it; MuJoCo
takes the larger of two geoms' values. A block of coefficient 0.2 slid on a floor of 1.0 on
MuJoCo's 1.0 (RLBench's hit_ball_with_queue: its ball of 0.1 stopped on a table of 0.71 where
Bullet lets it roll on 0.071). simx_server/sim/friction.py."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.sim import friction

pytestmark = pytest.mark.renderers_on_demand  # no image is read

_G = 9.81
_SPEED = 1.0  # m/s, the block's push


def _scene(tmp_path, block: float, floor: float, name: str = "slide", length: float = 2.0):
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.dynamics()
            + W.cuboid_shape(1, -1, "floor", (length, 1.0, 0.02), (0, 0, 0), dynamic=False,
                             material=W.bullet_material(floor, floor))
            + W.cuboid_shape(2, -1, "block", (0.05, 0.05, 0.05), (-0.5, 0, 0.035), mass=0.1,
                             moments=(0.05 ** 2 / 6,) * 3, material=W.bullet_material(block, block)))
    f = tmp_path / f"{name}.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / f"out_{name}", name)
    return xml


def _slide(sim: Simulation) -> tuple[float, float]:
    """(m the pushed block slid before it stopped, the friction of its contact with the floor)."""
    w = sim.world
    m, d = w.model, w.data
    block = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "block")
    dof = int(m.jnt_dofadr[m.body_jntadr[block]])
    for _ in range(4):  # settled on the floor
        w.step()
    start = float(d.xpos[block][0])
    d.qvel[dof] = _SPEED
    for _ in range(round(2.0 / w.dt)):
        w.step()
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "floor")
    mus = [float(d.contact.friction[i, 0]) for i in range(d.ncon)
           if {int(m.geom_bodyid[g]) for g in d.contact.geom[i]} == {block, floor}]
    assert mus, "the block rests on the floor"
    return float(d.xpos[block][0]) - start, mus[0]


def _run(xml, setup=None) -> tuple[float, float]:
    """:func:`_slide` in a new simulation of ``xml``; ``setup(api)`` first, before it starts."""
    sim = Simulation(xml, realtime=False)
    try:
        if setup is not None:
            setup(client_context(sim, "test").sim)
        sim.start()
        return _slide(sim)
    finally:
        sim.stop()
        sim.close()


def test_a_block_slides_on_the_product_of_the_two_coefficients(tmp_path):
    distance, mu = _run(_scene(tmp_path, 0.2, 1.0))
    assert mu == pytest.approx(0.2)  # MuJoCo's own: 1.0
    # v^2 / (2 mu g): 0.255 m on 0.2 (0.051 m on MuJoCo's 1.0)
    assert distance == pytest.approx(_SPEED ** 2 / (2 * 0.2 * _G), rel=0.12)


def test_a_scene_without_the_rule_keeps_mujocos_larger_value(tmp_path):
    xml = _scene(tmp_path, 0.2, 1.0)
    text = xml.read_text()
    assert '<text name="simx:scene:friction" data="combine=product"/>' in text
    xml.write_text(text.replace('data="combine=product"', 'data="combine=max"'))
    distance, mu = _run(xml)
    assert mu == pytest.approx(1.0)
    assert distance == pytest.approx(_SPEED ** 2 / (2 * 1.0 * _G), rel=0.25)


def test_an_unknown_rule_refuses_the_scene(tmp_path):
    xml = _scene(tmp_path, 0.2, 1.0)
    xml.write_text(xml.read_text().replace('data="combine=product"', 'data="combine=mean"'))
    with pytest.raises(ValueError, match="combine='mean'"):
        Simulation(xml, realtime=False)


def test_coefficients_read_and_set_as_v_rep_gives_them(tmp_path):
    """``sim.getEngineFloatParam(sim.bullet_body_friction)`` reads a shape's coefficient (stored
    squared), a set one slides as Bullet's product, and a shape made at run time has
    CoppeliaSim's default material (0.71)."""
    def setup(api) -> None:
        block = api.getObject("/block")
        assert api.getEngineFloatParam(6003, block) == pytest.approx(0.2)
        api.setEngineFloatParam(6003, block, 0.5)
        assert api.getEngineFloatParam(6003, block) == pytest.approx(0.5)
        cube = api.createPrimitiveShape(3, [0.05, 0.05, 0.05])  # a cuboid
        assert api.getEngineFloatParam(6003, cube) == pytest.approx(0.71)

    distance, mu = _run(_scene(tmp_path, 0.2, 1.0), setup)
    assert mu == pytest.approx(0.5)
    assert distance == pytest.approx(_SPEED ** 2 / (2 * 0.5 * _G), rel=0.2)


def test_a_frictionless_shape_rests_on_the_floor_and_slides(tmp_path):
    """A coefficient of 0 (V-REP's BubbleRob slider) gives Bullet's product 0 against any floor:
    the contact keeps its normal force (MuJoCo's elliptic cone scales it by mu: at exactly 0 the
    block fell through) and the pushed block slides on at its speed."""
    sim = Simulation(_scene(tmp_path, 0.0, 1.0, length=6.0), realtime=False)
    try:
        sim.start()
        w = sim.world
        block = mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_BODY, "block")
        height = float(w.data.xpos[block][2])
        distance, mu = _slide(sim)
        assert float(w.data.xpos[block][2]) == pytest.approx(height, abs=2e-3)
    finally:
        sim.stop()
        sim.close()
    assert mu == pytest.approx(mujoco.mjMINMU)
    assert distance == pytest.approx(_SPEED * 2.0, rel=0.05)  # 2 s at 1 m/s, nothing brakes it


def _pair_model(f1: float, f2: float, condim: int = 3) -> mujoco.MjModel:
    """A box resting on a plane, of sliding frictions ``f1`` (plane) and ``f2`` (box)."""
    return mujoco.MjModel.from_xml_string(f"""
<mujoco><option cone="elliptic" impratio="10"/><worldbody>
  <geom type="plane" size="1 1 0.1" friction="{f1} 0.02 0.001" condim="{condim}"/>
  <body pos="0 0 0.049"><freejoint/>
    <geom type="box" size="0.05 0.05 0.05" friction="{f2} 0.02 0.001" condim="{condim}"/></body>
</worldbody></mujoco>""")


@pytest.mark.parametrize("condim", [3, 4, 6])
def test_combined_contacts_are_mujocos_own_for_that_friction(condim):
    """After :func:`friction.combine`, a contact of two values (1.0 and 0.25) has exactly the
    friction, cone ``mu`` and regularisation MuJoCo itself gives a contact of two geoms of the
    product (0.5): ``mj_makeImpedance``'s rules, torsion and rolling rows included."""
    mixed_m, own_m = _pair_model(1.0, 0.25, condim), _pair_model(0.5, 0.5, condim)
    mixed_d, own_d = mujoco.MjData(mixed_m), mujoco.MjData(own_m)
    mujoco.mj_step1(mixed_m, mixed_d)
    friction.combine(mixed_m, mixed_d)
    mujoco.mj_step1(own_m, own_d)
    assert mixed_d.ncon == own_d.ncon == 4
    np.testing.assert_allclose(mixed_d.contact.friction, own_d.contact.friction)
    np.testing.assert_allclose(mixed_d.contact.mu, own_d.contact.mu)
    np.testing.assert_allclose(mixed_d.efc_R[:mixed_d.nefc], own_d.efc_R[:own_d.nefc], rtol=1e-12)
    np.testing.assert_allclose(mixed_d.efc_D[:mixed_d.nefc], own_d.efc_D[:own_d.nefc], rtol=1e-12)


def test_combine_follows_frictions_and_models_changed_between_substeps():
    """:func:`friction.combine` keeps its last answer while the contacts' geoms and frictions are
    the same: a friction set between two substeps (``sim.setEngineFloatParam``), or another
    model's substep in between, gives that substep the product of the values it has now."""
    m, other = _pair_model(1.0, 0.25), _pair_model(0.09, 1.0)
    d, other_d = mujoco.MjData(m), mujoco.MjData(other)

    def substep(model, data) -> float:
        mujoco.mj_step1(model, data)
        friction.combine(model, data)
        mu = data.contact.friction[:, 0].copy()
        mujoco.mj_step2(model, data)
        assert len(mu) == 4
        assert np.all(mu == mu[0])
        return float(mu[0])

    assert substep(m, d) == pytest.approx(0.5)
    assert substep(m, d) == pytest.approx(0.5)  # the same contacts: the kept answer
    assert substep(other, other_d) == pytest.approx(0.3)
    assert substep(m, d) == pytest.approx(0.5)
    m.geom_friction[1, 0] = 0.04
    assert substep(m, d) == pytest.approx(0.2)
    own = _pair_model(0.2, 0.2)
    own_d = mujoco.MjData(own)
    own_d.qpos[:], own_d.qvel[:] = d.qpos, d.qvel
    mujoco.mj_step1(m, d)
    friction.combine(m, d)
    mujoco.mj_step1(own, own_d)
    np.testing.assert_allclose(d.contact.mu, own_d.contact.mu)


def test_combine_keeps_mujocos_value_beside_the_changed_contacts():
    """Contacts of equal values keep MuJoCo's friction beside those :func:`friction.combine`
    changes, at every substep of :func:`friction.steps` (its kept answer writes every contact),
    and once MuJoCo's override sets every contact's friction the kept answer is not reused: the
    override's value stays where both geoms agree."""
    m = mujoco.MjModel.from_xml_string("""
<mujoco><option cone="elliptic" o_friction="0.7 0.7 0.02 0.001 0.001"/><worldbody>
  <geom type="plane" size="1 1 0.1" friction="1.0 0.02 0.001"/>
  <body pos="0 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="0.25 0.02 0.001"/></body>
  <body pos="0.3 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="1.0 0.02 0.001"/></body>
</worldbody></mujoco>""")
    d = mujoco.MjData(m)

    def frictions() -> dict[int, set[float]]:
        mujoco.mj_step1(m, d)
        friction.combine(m, d)
        out: dict[int, set[float]] = {}
        for g, f in zip(d.contact.geom[:, 1], d.contact.friction[:, :2]):
            out.setdefault(int(g), set()).update(np.round(f, 12).tolist())
        mujoco.mj_step2(m, d)
        return out

    for _ in range(3):
        assert frictions() == {1: {0.5}, 2: {1.0}}
    friction.steps(m, d, 5)
    assert frictions() == {1: {0.5}, 2: {1.0}}
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_OVERRIDE
    assert frictions() == {1: {0.5}, 2: {0.7}}


def test_steps_lowered_frictions_give_the_contacts_what_combine_gives():
    """:func:`friction.steps` lowers, for its substeps, the larger side of the contacts it
    starts with to their product, so that MuJoCo gives them Bullet's value itself; every other
    contact (one the lowering made wrong, one that appears during the step) is corrected by
    :func:`friction.combine`. Boxes of four materials pushed on a floor move as they do when
    every substep's contacts are combined from MuJoCo's own values (a box of 1.0 under a box of
    0.49, both lowered, keeps the floor's 1.0 and holds against a push its 0.7 would not), and
    the model's frictions are its own again after each call."""
    xml = """
<mujoco><option cone="elliptic" impratio="10"/><worldbody>
  <geom type="plane" size="2 2 0.1" friction="1.0 0.02 0.001"/>
  <body pos="0 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="0.25 0.02 0.001"/></body>
  <body pos="0.3 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="1.0 0.02 0.001"/></body>
  <body pos="0.6 0 0.08"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="0.0625 0.02 0.001"/></body>
  <body pos="0.3 0 0.1395"><freejoint/><geom type="box" size="0.04 0.04 0.04" friction="0.49 0.02 0.001"/></body>
</worldbody></mujoco>"""
    ours, ref = mujoco.MjModel.from_xml_string(xml), mujoco.MjModel.from_xml_string(xml)
    d, d_ref = mujoco.MjData(ours), mujoco.MjData(ref)
    own = ours.geom_friction.copy()
    for data in (d, d_ref):
        data.qvel[[0, 12]] = 0.6  # the boxes of 0.25 and 0.0625 pushed along x
        data.xfrc_applied[2, 0] = 12.0  # N: the box of 1.0 (1 kg, 0.51 kg on it) pushed, held at 14.8
        mujoco.mj_forward(ours, data)
    lowered_seen = False
    for _ in range(40):
        friction.steps(ours, d, 5)
        np.testing.assert_array_equal(ours.geom_friction, own)
        lowered_seen |= friction._lowered(ours, d, friction._frictions(ours)) is not None
        for _ in range(5):  # the reference: MuJoCo's own values at every substep, then combined
            mujoco.mj_step1(ref, d_ref)
            fg = ref.geom_friction[:, 0].take(d_ref.contact.geom)
            want = np.where(fg[:, 0] == fg[:, 1], fg[:, 0], np.sqrt(fg[:, 0] * fg[:, 1]))
            friction.combine(ref, d_ref)
            np.testing.assert_allclose(d_ref.contact.friction[:, 0], want, rtol=1e-12)
            mujoco.mj_step2(ref, d_ref)
    assert lowered_seen
    np.testing.assert_allclose(d.qpos, d_ref.qpos, atol=1e-6)
    np.testing.assert_allclose(d.qvel, d_ref.qvel, atol=1e-5)
    assert d.qpos[14] > 0.65  # the box of 0.0625 slid on 0.25 (MuJoCo's larger value, 1, stops it in 2 cm)
    assert abs(d.qpos[7] - 0.3) < 1e-3  # the pushed box of 1.0 held


@pytest.mark.parametrize("condim", [3, 4, 6])
def test_forward_is_mj_forward_with_the_contacts_combined_before_the_acceleration_stage(condim):
    """:func:`friction.forward` combines the contacts right after the position stage and runs
    the rest of ``mj_forward`` from there: the same accelerations, forces, sensors and energy,
    bit for bit, as MuJoCo's stages run one by one with the contacts combined just before the
    acceleration stage (the velocity stage reads nothing the rule writes)."""
    m = mujoco.MjModel.from_xml_string(f"""
<mujoco><option cone="elliptic" impratio="10"><flag energy="enable"/></option><worldbody>
  <geom type="plane" size="1 1 0.1" friction="1 0.02 0.001" condim="{condim}"/>
  <body pos="0 0 0.045"><freejoint/><geom type="box" size="0.05 0.05 0.05" friction="0.25 0.02 0.001"
    condim="{condim}"/><site name="s" type="box" size="0.06 0.06 0.06"/></body>
</worldbody><sensor><touch site="s"/><framepos objtype="site" objname="s"/></sensor></mujoco>""")
    ours, stages = mujoco.MjData(m), mujoco.MjData(m)
    ours.qvel[0] = 0.3
    for _ in range(20):
        friction.steps(m, ours, 3)
        mujoco.mj_copyData(stages, m, ours)
        friction.forward(m, ours)
        mujoco.mj_fwdPosition(m, stages)
        mujoco.mj_sensorPos(m, stages)
        mujoco.mj_energyPos(m, stages)
        mujoco.mj_fwdVelocity(m, stages)
        mujoco.mj_sensorVel(m, stages)
        mujoco.mj_energyVel(m, stages)
        friction.combine(m, stages)
        mujoco.mj_forwardSkip(m, stages, int(mujoco.mjtStage.mjSTAGE_VEL), 0)
        assert ours.ncon == stages.ncon > 0
        for name in ("qacc", "efc_force", "efc_aref", "efc_R", "sensordata", "energy"):
            np.testing.assert_array_equal(getattr(ours, name), getattr(stages, name), err_msg=name)
        np.testing.assert_array_equal(ours.contact.mu, stages.contact.mu)
    assert ours.sensordata[0] > 0  # the touch sensor reads the box's weight


def test_contact_geoms_reads_each_substeps_contacts_without_building_the_list():
    """:func:`friction.contact_geoms` is a view of the MjData's contact buffer: its first
    ``ncon`` rows are ``d.contact.geom`` at every substep, as contacts come and go and after a
    reset; another MjData of the model has its own view; the view does not keep its MjData."""
    import gc
    import weakref

    m = mujoco.MjModel.from_xml_string("""
<mujoco><worldbody><geom type="plane" size="2 2 0.1"/>
  <body pos="0 0 0.3"><freejoint/><geom type="sphere" size="0.05"/></body>
  <body pos="0.3 0 0.6"><freejoint/><geom type="box" size="0.05 0.05 0.05"/></body>
</worldbody></mujoco>""")
    d, other = mujoco.MjData(m), mujoco.MjData(m)
    view = friction.contact_geoms(d)
    seen = set()
    for step in range(400):
        if step == 200:
            mujoco.mj_resetData(m, d)
        mujoco.mj_step1(m, d)
        assert friction.contact_geoms(d) is view
        np.testing.assert_array_equal(view[:d.ncon], d.contact.geom)
        seen.add(d.ncon)
        mujoco.mj_step2(m, d)
    assert {0, 1, 5} <= seen  # nothing, the ball on the floor, the box resting beside it too
    mujoco.mj_step1(m, other)
    assert friction.contact_geoms(other) is not view
    gone = weakref.ref(d)
    del d, view
    gc.collect()
    assert gone() is None
