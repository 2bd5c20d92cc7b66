"""Every real file of ``../shared/ttt-corpus`` converts; its objects by type match the file's
(names, parents, world poses within 1e-5 m, computed here from the file's local poses); each
loads and steps 1 s with no NaN and no free body falling through a static floor. Skips with the
reason where the folder is absent; fails when ``CI`` is set (conftest.require_shared)."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from simx_server.scene.ttt import convert, reader

try:
    from conftest import ROOT, SHARED, require_shared
except ImportError:
    from tests.conftest import ROOT, SHARED, require_shared

CORPUS = SHARED / "ttt-corpus"
#: The corpus's file names; without the folder, one test that skips naming the folder.
FILES = sorted(p.name for p in CORPUS.glob("*.tt[tm]")) if CORPUS.is_dir() else [""]
CORPUS_WHAT = "the corpus of real V-REP / CoppeliaSim scene files"
#: "not carried over" kinds per corpus file when issue 41 began: a report never names more.
NOT_CARRIED_THEN = {
    'BTIRAI+youbot__youbot_simple_example.ttt': 4,
    'Ianlande+Vrep_yolov3_ddpg_pytorch__scenes_scene.ttt': 4,
    'RL-LDV-TUM+epuck-vrep__epuck_test.ttt': 3,
    'jchoi2507+CoppeliaSim_Remote_API__UR10_UR10_Linear_Movement_Test.ttt': 4,
    'jchoi2507+CoppeliaSim_Remote_API__UR5_Deep_Fry_Simulation_v1_UR5_Deep_Fry_Simulation.ttt': 4,
    'jchoi2507+CoppeliaSim_Remote_API__UR5_Deep_Fry_Simulation_v2_UR5_Deep_Fry_Simulationv2.ttt': 4,
    'pranavraj575+swarm_coppeliasim__ros_ctrl_models_quad_copter.ttm': 2,
    'pranavraj575+swarm_coppeliasim__scenes_testSceneForModelDevelopmentv2.ttt': 3,
    'rhenandias+coppeliasim-scara-python__scene.ttt': 3,
    'salkhan23+ITCortex__vrep_objects_BubbleRob.ttm': 3,
    'salkhan23+ITCortex__vrep_objects_ItCortexRobot.ttm': 1,
    'salkhan23+ITCortex__vrep_objects_bowl.ttm': 1,
    'salkhan23+ITCortex__vrep_scenes_Kitchen_scene.ttt': 4,
    'salkhan23+ITCortex__vrep_scenes_Kitchen_scene_Bryan.ttt': 4,
    'salkhan23+ITCortex__vrep_scenes_hrr_task_micro.ttt': 2,
    'salkhan23+ITCortex__vrep_scenes_object_environment.ttt': 3,
    'salkhan23+ITCortex__vrep_scenes_vrep_IT.ttt': 2,
    'salkhan23+ITCortex__vrep_scenes_vrep_it_cortex.ttt': 7,
}
#: docs/PORTING.md's table of the corpus's reports: file -> its columns (kinds not carried over,
#: their count, kinds approximated), which each file's test checks against its report.
DOC_NOW = {m[1]: (int(m[2]), int(m[3].replace(",", "")), int(m[4])) for m in re.finditer(
    r"^\| `([^`]+\.tt[tm])` \| (\d+) \| ([\d,]+) \| (\d+) \|$",
    (ROOT / "docs" / "PORTING.md").read_text(), re.M)}
_ELEMENT = {"shape": mujoco.mjtObj.mjOBJ_BODY, "dummy": mujoco.mjtObj.mjOBJ_SITE,
            "force_sensor": mujoco.mjtObj.mjOBJ_SITE, "proximity_sensor": mujoco.mjtObj.mjOBJ_SITE,
            "vision_sensor": mujoco.mjtObj.mjOBJ_CAMERA, "joint": mujoco.mjtObj.mjOBJ_JOINT,
            "light": mujoco.mjtObj.mjOBJ_LIGHT}


def _rot(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _file_world_poses(scene):
    """World (position, rotation) of every object from the file's local poses: a child of a
    joint is posed from the joint frame turned (revolute) or moved (prismatic) by its position."""
    out = {}

    def walk(obj, p, r):
        pw, rw = p + r @ obj.pose.pos, r @ _rot(obj.pose.quat)
        out[obj.handle] = (pw, rw)
        if obj.kind == "joint" and obj.data.type == 10:
            a = obj.data.position
            rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
            pc, rc = pw, rw @ rz
        elif obj.kind == "joint" and obj.data.type == 11:
            pc, rc = pw + rw @ np.array([0, 0, obj.data.position]), rw
        else:
            pc, rc = pw, rw
        for c in obj.children:
            walk(c, pc, rc)

    for root in scene.roots:
        walk(root, np.zeros(3), np.eye(3))
    return out


@pytest.mark.parametrize("name", FILES, ids=lambda name: name or "ttt-corpus")
def test_corpus_file_converts_loads_and_steps(name, tmp_path):
    path = require_shared(CORPUS / name, CORPUS_WHAT if not name else "a file of the corpus of real scene files")
    scene = reader.read(path)
    xml, report = convert.convert(scene, tmp_path, "scene")
    # the load report names no more kinds left out than when issue 41 began, and
    # what was carried over in a close form (meshes colliding as their hull) as approximated
    assert len(report.lines()) <= NOT_CARRIED_THEN[name], report.lines()
    now = (len(report.lines()), sum(report.counts[k] for k in report.counts if k not in report.approximated),
           len(report.approximations()))
    assert DOC_NOW.get(name) == now, f"docs/PORTING.md's row of {name}: now {now}, {report.lines()}"
    assert not any("convex hull" in line for line in report.lines())
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_camlight(m, d)
    expected = _file_world_poses(scene)
    checked = 0
    for obj in scene.objects.values():
        kind = _ELEMENT.get(obj.kind)
        if kind is None:
            continue
        i = mujoco.mj_name2id(m, kind, obj.name)
        assert i >= 0, f"{name}: {obj.kind} {obj.name!r} missing from the MJCF"
        pos, rot = expected[obj.handle]
        if kind == mujoco.mjtObj.mjOBJ_BODY:
            got, grot = d.xpos[i], d.xmat[i].reshape(3, 3)
            np.testing.assert_allclose(grot, rot, atol=1e-4, err_msg=f"{name}: orientation of {obj.name!r}")
            parent = scene.objects.get(obj.parent)
            if parent is not None and parent.kind == "shape" and m.body_jntnum[i] == 0:
                assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, m.body_parentid[i]) == parent.name, \
                    f"{name}: parent of {obj.name!r}"
        elif kind == mujoco.mjtObj.mjOBJ_SITE:
            got = d.site_xpos[i]
        elif kind == mujoco.mjtObj.mjOBJ_CAMERA:
            got = d.cam_xpos[i]
        elif kind == mujoco.mjtObj.mjOBJ_LIGHT:
            got = d.light_xpos[i]
        else:  # a joint's anchor: its frame's origin (prismatic: the displaced one)
            got = d.xanchor[i]
            if obj.data.type == 11:
                pos = pos + rot @ np.array([0, 0, obj.data.position])
            if obj.data.type == 12:
                continue
        np.testing.assert_allclose(got, pos, atol=1e-5, err_msg=f"{name}: world position of {obj.kind} {obj.name!r}")
        checked += 1
    assert checked >= len([o for o in scene.objects.values() if o.kind in ("shape", "joint")])
    # 1 s of simulation: finite, and no free body below the static floor it started above
    static_tops = [d.geom_xpos[g][2] + m.geom_size[g][2] for g in range(m.ngeom)
                   if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and m.geom_contype[g]
                   and m.body_weldid[m.geom_bodyid[g]] == 0 and min(m.geom_size[g][:2]) > 1.0]
    floor = max(static_tops) if static_tops else None
    free = [b for b in range(m.nbody) if m.body_jntnum[b] == 1 and m.jnt_type[m.body_jntadr[b]] == 0]
    start = {b: d.xpos[b][2] for b in free}
    for _ in range(int(round(1.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel)), f"{name}: NaN after 1 s"
    if floor is not None:
        for b in free:
            if start[b] > floor:
                assert d.xpos[b][2] > floor - 0.05, \
                    f"{name}: {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)!r} fell through the floor"
