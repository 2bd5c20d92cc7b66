"""The VPG-style program (tests/scripts/vpg_style_program.py) against a real server on scenes/ur5_ik.xml:
restart, camera, three imported cubes, grasp-and-lift, push; and the scene's
``remoteApiCommandServer`` script's errors.

The server runs asynchronously at ``--speed 0`` (steps back to back), so that the program's
simulated seconds take wall milliseconds on CI; the program never relies on the pacing of
blocking calls: it polls the tip until it rests on the target and the gripper until it stops,
so it runs the same at ``--speed 1`` (visual-pushing-grasping's real time), only slower.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys

import pytest

import vrep

try:
    from conftest import ROOT, ServerProcess, free_port
except ImportError:  # tests/ imported as a package
    from tests.conftest import ROOT, ServerProcess, free_port

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
IK_SCENE = ROOT / "scenes" / "ur5_ik.xml"
PROGRAM = ROOT / "tests" / "scripts" / "vpg_style_program.py"
BLOCK = vrep.simx_opmode_blocking
LEGACY_PORT = 19997  # visual-pushing-grasping's port


def _port() -> int:
    """19997 when it is free on 127.0.0.1 (the program's default), else any free port."""
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", LEGACY_PORT))
        except OSError:
            return free_port()
    return LEGACY_PORT


@pytest.fixture(scope="module")
def vpg_server(tmp_path_factory):
    """The ur5_ik scene at --speed 0; ``srv.mesh_dir`` is the --scene-path folder the tests
    write meshes into (sim.importShape reads only from trusted folders)."""
    port = _port()
    mesh_dir = tmp_path_factory.mktemp("meshes")
    args = (str(IK_SCENE), "--speed", "0", "--scene-path", str(mesh_dir))
    try:
        srv = ServerProcess(*args, ports=[port])
    except RuntimeError as exc:  # lost a race for 19997
        if "cannot listen" not in str(exc):
            raise
        srv = ServerProcess(*args, ports=[free_port()])
    srv.mesh_dir = mesh_dir
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log


def test_vpg_style_program_grasps_lifts_and_pushes(vpg_server):
    """The program exits 0: tip on target after the restart, a 640x480 image and a depth of the
    table 1 m below the camera, three handles, the first cube lifted over 0.1 m, the tip within
    2 mm of the target at rest while it holds the cube, the second cube pushed over 5 cm."""
    run = subprocess.run([sys.executable, str(PROGRAM), "--port", str(vpg_server.port), "--mesh-dir", str(vpg_server.mesh_dir)],
                         capture_output=True, text=True, timeout=120, cwd=vpg_server.mesh_dir)
    steps = {}
    for line in run.stdout.splitlines():
        record = json.loads(line)
        steps[record.pop("step")] = record
    print(run.stdout)
    assert run.returncode == 0, (run.stdout, run.stderr, vpg_server.stop())
    assert steps["restarted"]["tip_error"] < 0.002
    assert steps["camera"]["shape"] == [480, 640, 3]
    assert steps["camera"]["depth_median"] == pytest.approx(1.0, abs=0.05)  # the table top
    assert steps["camera"]["colours"] > 50  # a picture, not a blank
    handles = steps["added"]["handles"]
    assert len(set(handles)) == 3
    # the cubes' tops, 0.95 m from the camera, cover the area the 618.62 px focal length gives
    assert steps["cube_tops"]["pixels"] == pytest.approx(steps["cube_tops"]["expected"], rel=0.1)
    assert steps["grasped"]["after"][2] - steps["grasped"]["before"][2] > 0.1
    # the fingers stopped on the 5 cm cube: RG2_openCloseJoint near 0.025 / 0.6627 - 0.047
    assert -0.02 < steps["closed"]["opening"] < 0.0
    assert steps["tip_at_rest"]["error"] < 0.002
    assert steps["pushed"]["moved"] > 0.05

    # The imported shapes keep their handles under the names the program gave them, and the
    # server serves a new client as before.
    cid = vrep.simxStart("127.0.0.1", vpg_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        for i, handle in enumerate(handles):
            rc, h = vrep.simxGetObjectHandle(cid, f"shape_{i:02d}", BLOCK)
            assert (rc, h) == (vrep.simx_return_ok, handle)
        rc, pos = vrep.simxGetObjectPosition(cid, handles[2], -1, BLOCK)
        assert rc == vrep.simx_return_ok and pos[0] == pytest.approx(-0.65, abs=0.01)  # untouched cube
    finally:
        vrep.simxFinish(cid)


def _import(cid, mesh, name, ints=(0, 0, 255, 0)):
    return vrep.simxCallScriptFunction(cid, "remoteApiCommandServer", vrep.sim_scripttype_childscript,
                                       "importShape", list(ints), [-0.4, 0.2, 0.1, 0, 0, 0, 0.5, 0.5, 0.5],
                                       [str(mesh), name], bytearray(), BLOCK)


def test_import_shape_errors_answer_remote_error(vpg_server, tmp_path):
    """Bad imports answer the remote error flag with a log line naming the call and the file;
    nothing is added, and a good import afterwards works (its handle is new). A mesh outside
    the trusted folders is refused with the same words whether or not it exists."""
    outside = tmp_path
    tmp_path = vpg_server.mesh_dir
    cid = vrep.simxStart("127.0.0.1", vpg_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        vrep.simxStartSimulation(cid, BLOCK)
        _, before = vrep.simxGetObjects(cid, vrep.sim_handle_all, BLOCK)[:2]
        missing = tmp_path / "missing.obj"
        text = tmp_path / "notes.txt"
        text.write_text("v 0 0 0\n")
        broken = tmp_path / "broken.obj"
        broken.write_text("this is not a mesh\n")
        ascii_stl = tmp_path / "ascii.stl"
        ascii_stl.write_text("solid t\nendsolid t\n")
        for mesh, ints in ((missing, (0,)), (text, (0,)), (broken, (0,)), (tmp_path / "x.obj", (7,)),
                           (ascii_stl, (3,))):
            if mesh.name == "x.obj":
                mesh.write_text("v 0 0 0\n")
            rc, *_ = _import(cid, mesh, "bad", ints)
            assert rc == vrep.simx_return_remote_error_flag, mesh
        refusals = []
        for mesh in (outside / "exists.obj", outside / "absent.obj"):
            if mesh.name == "exists.obj":  # a good tetrahedron
                mesh.write_text("v 0 0 0\nv 0.04 0 0\nv 0 0.04 0\nv 0 0 0.04\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
            rc, *_ = _import(cid, mesh, "outside")
            assert rc == vrep.simx_return_remote_error_flag, mesh
            refusals.append(vrep.simxGetLastErrors(cid, BLOCK)[1][-1].replace(mesh.name, "NAME"))
        assert refusals[0] == refusals[1] and "refused" in refusals[0]
        _, after = vrep.simxGetObjects(cid, vrep.sim_handle_all, BLOCK)[:2]
        assert after == before
        good = tmp_path / "good.stl"
        good.write_bytes(_stl_tetra())
        rc, ints, *_ = _import(cid, good, "tetra_from_stl", (4,))  # 4: binary STL
        assert rc == vrep.simx_return_ok and ints[0] not in before
        assert vrep.simxGetObjectHandle(cid, "tetra_from_stl", BLOCK) == (vrep.simx_return_ok, ints[0])
    finally:
        vrep.simxFinish(cid)
    log = vpg_server.log
    log.seek(0)
    text_log = log.read()
    assert "sim.importShape" in text_log and "missing.obj" in text_log and "notes.txt" in text_log


def _stl_tetra() -> bytes:
    """A binary STL tetrahedron (4 cm)."""
    import struct
    v = [(0, 0, 0), (0.04, 0, 0), (0, 0.04, 0), (0, 0, 0.04)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    out = b"simx test tetrahedron".ljust(80, b" ") + struct.pack("<I", len(faces))
    for face in faces:
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v[i]) for i in face) + b"\0\0"
    return out


def test_shape_colour_and_name_through_the_facade(tmp_path):
    """In process: sim.setShapeColor changes the imported geom's colour (and keeps it through a
    later edit of the scene); sim.setObjectName renames with the handle kept; the IK group is
    rebuilt on the edited model and the tip still follows its target."""
    import numpy as np

    from simx_server.api import script_sim
    from simx_server.scene.simulation import Simulation

    sim = Simulation(IK_SCENE, dt=0.05, realtime=False, scene_paths=[tmp_path])
    w = sim.world
    sim.start()
    mesh = tmp_path / "cube.obj"
    sys.path.insert(0, str(PROGRAM.parent))
    try:
        from vpg_style_program import write_cube
    finally:
        sys.path.remove(str(PROGRAM.parent))
    write_cube(str(mesh), 0.04)
    f = script_sim(w, w.resolve("remoteApiCommandServer").handle, sim.signals, simulation=sim)
    h = f.importShape(0, str(mesh), 0, 0.0, 1.0)
    assert f.setShapeColor(h, None, 0, [0.1, 0.2, 0.3]) == 1
    geom = int(np.flatnonzero(w.model.geom_bodyid == w.get(h).mj_id)[0])
    assert w.model.geom_rgba[geom][:3] == pytest.approx([0.1, 0.2, 0.3])
    f.setObjectName(h, "red_cube")
    assert w.resolve("red_cube").handle == h and f.getObjectName(h) == "red_cube"
    h2 = f.importShape(0, str(mesh), 0, 0.0, 0)  # another edit (scale 0: 1, as absent)
    assert h2 != h and w.resolve("red_cube").handle == h
    geom = int(np.flatnonzero(w.model.geom_bodyid == w.get(h).mj_id)[0])
    assert w.model.geom_rgba[geom][:3] == pytest.approx([0.1, 0.2, 0.3])  # the colour survived
    with pytest.raises(Exception, match="taken by another object"):
        f.setObjectName(h2, "red_cube")
    f.setShapeColor(h, None, 0, [2, 0, 0])  # kept by CoppeliaSim, clamped when drawn
    assert w.model.geom_rgba[geom][:3] == pytest.approx([1, 0, 0])
    with pytest.raises(Exception, match="must be finite"):
        f.setShapeColor(h, None, 0, [float("nan"), 0, 0])
    with pytest.raises(Exception, match="MAX_IMPORT_BYTES"):
        big = tmp_path / "big.obj"
        big.write_bytes(b"#" * (17 * 1024 * 1024))
        f.importShape(0, str(big), 0, 0.0, 1.0)
    target = w.resolve("UR5_target").handle
    w.set_pose(target, -1, [-0.45, 0.12, 0.2])
    for _ in range(40):
        sim.step()
    tip = np.array(w.position(w.resolve("UR5_tip").handle, -1))
    assert np.linalg.norm(tip - [-0.45, 0.12, 0.2]) < 0.002
    sim.close()


def test_imported_shapes_stay_in_place_when_the_simulation_stops(tmp_path):
    """A stop puts the scene's own objects back, not imported shapes: they stay where they are
    (their model pose is the origin, inside the robot's base and the table)."""
    from simx_server.api import script_sim
    from simx_server.scene.simulation import Simulation

    sys.path.insert(0, str(PROGRAM.parent))
    try:
        from vpg_style_program import write_cube
    finally:
        sys.path.remove(str(PROGRAM.parent))
    mesh = tmp_path / "cube.obj"
    write_cube(str(mesh), 0.05)
    sim = Simulation(IK_SCENE, dt=0.05, realtime=False, scene_paths=[tmp_path])
    w = sim.world
    sim.start()
    f = script_sim(w, w.resolve("remoteApiCommandServer").handle, sim.signals, simulation=sim)
    h = f.importShape(0, str(mesh), 0, 0.0, 1.0)
    f.setObjectPosition(h, -1, [-0.5, 0.1, 0.05])
    for _ in range(10):
        sim.step()
    rest = w.position(h, -1)
    assert rest[2] == pytest.approx(0.025, abs=0.002)  # fell onto the table
    sim.stop()
    assert w.position(h, -1) == pytest.approx(rest, abs=1e-6)
    sim.start()
    for _ in range(10):
        sim.step()
    assert w.position(h, -1) == pytest.approx(rest, abs=1e-3)
    sim.close()
