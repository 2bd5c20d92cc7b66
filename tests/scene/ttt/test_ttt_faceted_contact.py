"""Two convex meshes of many near-coplanar facets (a convex decomposition's hulls) resting face
to face stay so, as on Bullet, whose persistent manifold keeps up to four points across the face
(CoppeliaSim 4.1's Bullet 2.78 ``btConvexHullShape``s). MuJoCo 3.x's native convex collision
gives such a pair the points of one small facet, on one side of the face and on alternate sides
from substep to substep, and a light body rocks on it: RLBench's 1 kg jar lid (inertia 6.9e-5
kg m2) rocked at 10 rad/s and went through its jar's 7 mm neck during the ten steps of a reset.
A converted scene collides with libccd's, whose points span the face."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader


def _faceted_disc(radius: float, height: float, seed: int, rings: int = 3, per_ring: int = 24,
                  jitter: float = 2e-4):
    """A disc (m) of ``rings`` rings of points on each face, every point's height jittered by
    up to ``jitter``: its hull's faces are many small facets a fraction of a degree apart;
    vertices (N, 3) and triangles that use every vertex (MuJoCo collides the hull)."""
    rng = np.random.default_rng(seed)
    ring = []
    for k in range(1, rings + 1):
        a = rng.uniform(0, 2 * np.pi) + np.linspace(0, 2 * np.pi, per_ring, endpoint=False)
        ring += [(radius * k / rings * np.cos(t), radius * k / rings * np.sin(t)) for t in a]
    xy = np.array(ring)
    v = np.r_[np.c_[xy, np.full(len(xy), height / 2)], np.c_[xy, np.full(len(xy), -height / 2)]]
    v[:, 2] += rng.uniform(-jitter, jitter, len(v))
    faces = np.array([[i, i + 1, i + 2] for i in range(len(v) - 2)])
    return v, faces


@pytest.mark.parametrize("seed", [3, 4])
def test_a_light_lid_rests_on_a_faceted_neck(tmp_path, seed):
    neck_v, neck_f = _faceted_disc(0.034, 0.0067, seed)
    lid_v, lid_f = _faceted_disc(0.036, 0.0211, seed + 10)
    glass = W.bullet_material(0.71)
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.dynamics()
            + W.mesh_shape(1, -1, "neck", neck_v, neck_f, pos=(0, 0, 0.5), dynamic=False, material=glass)
            + W.mesh_shape(2, -1, "lid", lid_v, lid_f, pos=(0, 0, 0.5 + 0.00335 + 0.01055 + 0.0004),
                           mass=1.0, moments=(6.87e-5,) * 3, material=glass))
    f = tmp_path / "jar.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "jar")
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    lid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "lid")
    mujoco.mj_forward(m, d)
    start = d.xpos[lid].copy()
    spin = 0.0
    for i in range(round(2 / m.opt.timestep)):  # 2 s
        mujoco.mj_step(m, d)
        if i * m.opt.timestep > 0.1:  # settled on the neck
            spin = max(spin, float(np.linalg.norm(d.cvel[lid][:3])))
    # native CCD: it rocks at 3 to 5 rad/s and walks 2.5 to 3 mm (libccd: 0.03 rad/s, 0 mm)
    assert spin < 0.3
    assert np.linalg.norm(d.xpos[lid] - start) < 5e-4
