"""Issue 23 part 3: what a client's scene may cost the server, measured after MuJoCo compiles it
and before it replaces the current scene, and bounded again while it runs.

* The data arena MuJoCo sizes itself (``narena``: 300 free spheres 227 MiB, 1,000 1.65 GiB)
  against ``MAX_ARENA_BYTES``; the contacts of the scene as loaded (collision detection alone,
  no solver) against ``MAX_SCENE_CONTACTS``; substeps x iterations x geoms against
  ``MAX_STEP_WORK``. A refused scene changes nothing and its MjData is never made.
* A step of a client's scene runs its substeps one at a time: past ``MAX_STEP_SECONDS`` of the
  simulation thread the simulation stops and every client is told (the operator's own scenes
  are not cut).
* Mesh vertices are counted as MuJoCo's readers take them (OBJ lines after CR, LF or CRLF,
  with leading blanks; binary STL whatever its header says), never fewer than MuJoCo loads.
"""

from __future__ import annotations

import struct

import mujoco
import numpy as np
import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client.protocol import RemoteError
from simx_server.base import limits as L
from simx_server.base.scene_guard import mesh_vertices

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

B = vrep.simx_opmode_blocking


def spheres(n: int, gap: float = 0.001, memory: str = "", iterations: int = 100) -> bytes:
    """``n`` free spheres of radius 5 cm in a column ``gap`` m apart (1 mm: all overlapping)."""
    bodies = "".join(f'<body name="s{i}" pos="0 0 {0.1 + i * gap:.3f}"><freejoint/><geom size="0.05"/></body>'
                     for i in range(n))
    size = f'<size memory="{memory}"/>' if memory else ""
    return (f'<mujoco><option iterations="{iterations}"/>{size}<worldbody>{bodies}</worldbody>'
            '</mujoco>').encode()


@pytest.fixture
def sim():
    from simx_server.scene.simulation import Simulation

    s = Simulation(SCENE, dt=0.05, realtime=False)
    yield s
    s.close()


@pytest.fixture
def H():
    from simx_server.commands.editing import EDITING_HANDLERS

    return EDITING_HANDLERS


def test_overlapping_bodies_are_refused_by_their_contacts_before_any_step(sim, H, monkeypatch):
    """100 overlapping spheres fit a 32 MiB arena and the step-work estimate, and make 4,950
    contacts: their first substep took 1.4 s (300 of them 30 s). Counting them costs a
    collision pass; no solver runs."""
    world = sim.world
    solved = []
    for name in ("mj_forward", "mj_step"):
        real = getattr(mujoco, name)
        monkeypatch.setattr(mujoco, name, lambda m, d, *a, _real=real, **k: (solved.append(m.nbody), _real(m, d, *a, **k))[1])
    H["TransferFile"](sim, ["pile.xml", spheres(100, memory="32M")])
    with pytest.raises(RemoteError, match=r"contacts as loaded, more than 2,000 \(simx_server.base.limits.MAX_SCENE_CONTACTS\)"):
        H["LoadScene"](sim, ["pile.xml", 1])
    assert sim.world is world and 101 not in solved  # nothing replaced, the pile never solved
    H["TransferFile"](sim, ["apart.xml", spheres(100, gap=0.2, memory="32M")])  # the same spheres apart
    H["LoadScene"](sim, ["apart.xml", 1])
    assert sim.world is not world and len(sim.world.objects) == 100


def test_the_arena_mujoco_sizes_itself_is_bounded_and_a_declared_one_passes(sim, H):
    H["TransferFile"](sim, ["auto.xml", spheres(120, gap=0.2)])  # MuJoCo's own arena: about 80 MiB
    with pytest.raises(RemoteError, match=r"MAX_ARENA_BYTES\) \(MuJoCo sizes it .* declare <size memory=\"64M\"/>"):
        H["LoadScene"](sim, ["auto.xml", 1])
    H["TransferFile"](sim, ["declared.xml", spheres(120, gap=0.2, memory="24M")])
    H["LoadScene"](sim, ["declared.xml", 1])
    assert sim.world.model.narena == 24 << 20 and len(sim.world.objects) == 120


def test_edits_that_overlap_bodies_past_the_bound_are_refused(sim, H, monkeypatch):
    monkeypatch.setattr(L, "MAX_SCENE_CONTACTS", 50)
    H["TransferFile"](sim, ["few.xml", spheres(8, memory="16M")])  # 28 contacts: within
    H["LoadScene"](sim, ["few.xml", 1])
    H["TransferFile"](sim, ["more.xml", spheres(8, memory="16M").replace(b'name="s', b'name="t')])
    with pytest.raises(RemoteError, match="MAX_SCENE_CONTACTS"):  # 16 overlapping: 120 contacts
        H["LoadModel"](sim, ["more.xml", 1])
    assert len(sim.world.objects) == 8


def test_a_client_scene_step_past_its_time_budget_stops_the_simulation(sim, H, monkeypatch):
    from simx_server.sim.physics import PhysicsError, StepTimeError
    from simx_server.sim.state import RunState

    sim.start()
    monkeypatch.setattr(L, "MAX_STEP_SECONDS", 0.0)
    sim.step()  # the operator's scene: never cut
    assert sim.state is RunState.RUNNING
    sim.stop()
    H["TransferFile"](sim, ["light.xml", spheres(5, gap=0.2)])
    H["LoadScene"](sim, ["light.xml", 1])
    sim.start()
    with pytest.raises(StepTimeError) as err:
        sim.step()
    assert isinstance(err.value, PhysicsError) and sim.state is RunState.STOPPED
    assert "MAX_STEP_SECONDS = 0 s" in sim.stop_reason and "1 of its 25 substeps" in sim.stop_reason
    monkeypatch.setattr(L, "MAX_STEP_SECONDS", 10.0)
    sim.start()
    sim.step()  # within the budget it runs, all its substeps
    assert sim.state is RunState.RUNNING and sim.world.time == pytest.approx(0.05)


def test_a_client_scene_of_bullets_friction_keeps_its_budget_and_its_frictions(sim, H, monkeypatch):
    """A client's scene with Bullet's friction (its substeps through ``friction.steps``, the
    larger side of its contacts lowered for them) is cut after the substep that ends past
    MAX_STEP_SECONDS, with its geoms' own frictions back; within the budget its contact has the
    product of the two coefficients."""
    from simx_server.sim.physics import StepTimeError

    scene = (b'<mujoco><option cone="elliptic"/><custom><text name="simx:scene:friction" data="combine=product"/>'
             b'</custom><worldbody><geom name="floor" type="plane" size="1 1 .1" friction="1 0.005 0.0001"/>'
             b'<body name="box" pos="0 0 0.0495"><freejoint/>'
             b'<geom type="box" size="0.05 0.05 0.05" friction="0.25 0.005 0.0001"/></body></worldbody></mujoco>')
    H["TransferFile"](sim, ["bullet.xml", scene])
    H["LoadScene"](sim, ["bullet.xml", 1])
    own = sim.world.model.geom_friction.copy()
    sim.start()
    sim.step()  # the box rests on the floor: the next step lowers the floor's value for its substeps
    monkeypatch.setattr(L, "MAX_STEP_SECONDS", 0.0)
    with pytest.raises(StepTimeError):
        sim.step()
    assert "1 of its 25 substeps" in sim.stop_reason
    np.testing.assert_array_equal(sim.world.model.geom_friction, own)
    monkeypatch.setattr(L, "MAX_STEP_SECONDS", 10.0)
    sim.start()
    for _ in range(2):
        sim.step()
    np.testing.assert_array_equal(sim.world.model.geom_friction, own)
    d = sim.world.data
    assert d.ncon and np.allclose(d.contact.friction[:, :2], 0.5)


def boxes(n: int) -> bytes:
    """``n`` boxes resting on a plane, solved by PGS for all of its 1,000 iterations (tolerance
    0): within every bound at load (600 contacts, substeps x iterations x geoms 3.8e6), and
    about 1.8 s a step on one core."""
    bodies = "".join(f'<body name="b{i}" pos="{(i % 10) * 0.25:.2f} {(i // 10) * 0.25:.2f} 0.1"><freejoint/>'
                     '<geom type="box" size="0.1 0.1 0.1"/></body>' for i in range(n))
    return (f'<mujoco><option iterations="1000" tolerance="0" solver="PGS"/><size memory="32M"/><worldbody>'
            f'<geom type="plane" size="10 10 .1"/>{bodies}</worldbody></mujoco>').encode()


def test_a_heavy_client_scene_is_stopped_on_a_real_server_and_every_client_told(tmp_path):
    """A client's scene within every bound at load whose steps take seconds: the first step
    stops after MAX_STEP_SECONDS and the reason reaches the client at its next call."""
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", "--stopped", ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        (tmp_path / "heavy.xml").write_bytes(boxes(150))
        rc = vrep.simxLoadScene(cid, str(tmp_path / "heavy.xml"), 1, B)  # options 1: sent from here
        assert rc == 0, vrep.simxGetLastErrors(cid, B)
        assert vrep.simxStartSimulation(cid, B) == 0
        reason = wait_until(lambda: _stop_reason(cid), timeout=60, what="the slow step reported")
        assert "MAX_STEP_SECONDS = 1 s" in reason, reason
        assert vrep.simxGetObjectHandle(cid, "b0", B)[0] == 0 and srv.proc.poll() is None
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "MAX_STEP_SECONDS" in log


def _stop_reason(cid: int) -> str | None:
    """The failed step's reason, once the client's next call is answered with it."""
    if vrep.simxGetObjectHandle(cid, "b0", B)[0] != vrep.simx_return_remote_error_flag:
        return None
    rc, errors = vrep.simxGetLastErrors(cid, B)
    return next((e for e in errors if "MAX_STEP_SECONDS" in e), None)


# ------------------------------------------------------------------ meshes
_TETRA = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"


def _stl(n: int, header: bytes) -> bytes:
    rng = np.random.default_rng(7)
    faces = b"".join(struct.pack("<12fH", 0, 0, 1, *rng.random(9), 0) for _ in range(n))
    return header.ljust(80, b"\0") + struct.pack("<I", n) + faces


def _mujoco_vertices(name: str, data: bytes) -> int | None:
    spec = mujoco.MjSpec()
    spec.assets = {name: data}
    spec.add_mesh(name="m", file=name)
    try:
        return int(spec.compile().mesh_vertnum[0])
    except ValueError:
        return None


MESHES = {
    "lf.obj": _TETRA,
    "cr.obj": _TETRA.replace(b"\n", b"\r"),
    "crlf.obj": _TETRA.replace(b"\n", b"\r\n"),
    "blanks.obj": _TETRA.replace(b"v ", b" \t v\t"),
    "tab-after-v.obj": _TETRA.replace(b"v ", b"v\t"),
    "UPPER.OBJ": _TETRA.replace(b"\n", b"\r"),
    "binary.stl": _stl(300, b"made by a CAD program"),
    "solid-header.stl": _stl(300, b"solid but binary"),  # was counted as ASCII STL: 0 vertices
}


@pytest.mark.parametrize("name", sorted(MESHES))
def test_mesh_vertices_are_never_fewer_than_mujoco_reads(name):
    data = MESHES[name]
    loaded = _mujoco_vertices(name, data)
    assert loaded is not None and loaded > 0, f"MuJoCo did not load {name}"
    assert mesh_vertices(data, name) >= loaded


def test_a_mesh_past_the_bound_in_any_line_ending_is_refused_before_mujoco_reads_it(sim, H, monkeypatch):
    monkeypatch.setattr(L, "MAX_MESH_VERTICES", 1000)
    rows = b"".join(b"v %d %d %d\n" % (i % 7, i % 11, i % 13) for i in range(1500)) + b"f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
    variants = {"cr.obj": rows.replace(b"\n", b"\r"), "blank.obj": rows.replace(b"v ", b"  v "),
                "solid.stl": _stl(400, b"solid header, binary body")}
    for file, data in variants.items():
        H["TransferFile"](sim, [file, data])
        scene = f'<mujoco><asset><mesh name="m" file="{file}"/></asset><worldbody><geom type="mesh" mesh="m"/>' \
                '</worldbody></mujoco>'
        H["TransferFile"](sim, ["mesh_scene.xml", scene.encode()])
        with pytest.raises(RemoteError, match="more than MAX_MESH_VERTICES = 1,000"):
            H["LoadScene"](sim, ["mesh_scene.xml", 1])
