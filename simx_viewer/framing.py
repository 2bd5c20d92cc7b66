"""The viewer's first view: the scene's own objects framed from a V-REP-like three-quarter view.

The box around every geom of a body (the world body's geoms, planes and the floor among them,
left out: they are unbounded or the ground), seen from :data:`AZIMUTH` and :data:`ELEVATION`, at
the distance where the box's bounding sphere fills the free camera's vertical field of view. A
scene may name its own view in a custom text ``simx:view`` (``lookat=x,y,z distance=m
azimuth=deg elevation=deg``, any of them).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

#: V-REP's default scene view looks at the floor's origin from the front right, from above.
AZIMUTH = 135.0  # degrees
ELEVATION = -25.0  # degrees
#: Half the view's height at the look-at point over the bounding sphere's radius: above 1 the
#: sphere fits with room around it, for what the box leaves out and the viewer draws (a vision
#: sensor's frustum, a shadow) and for a wide window's short side. At 0.85 an 853x533 window cut
#: the Kinect's frustum and a table leg and put the gripper 20 px from the top.
MARGIN = 1.25


def scene_settings(model: mujoco.MjModel) -> dict[str, str]:
    """The ``simx:view`` text of the model as key -> value, empty when it has none."""
    for i in range(model.ntext):
        if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i) == "simx:view":
            adr, size = model.text_adr[i], model.text_size[i]
            text = bytes(model.text_data[adr:adr + size - 1]).decode(errors="replace")
            return dict(item.split("=", 1) for item in text.split() if "=" in item)
    return {}


def scene_box(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` corners (m, world frame) of the box around every geom of a body but the
    world (planes and the floor left out), from each geom's own box (``geom_aabb``) turned into
    the world frame."""
    keep = np.nonzero((model.geom_bodyid > 0) & (model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE))[0]
    if not len(keep):
        return np.full(3, -1.0), np.full(3, 1.0)
    aabb = model.geom_aabb[keep]  # (n, 6): centre and half sizes in the geom's frame
    rot = data.geom_xmat[keep].reshape(-1, 3, 3)
    centre = data.geom_xpos[keep] + np.einsum("nij,nj->ni", rot, aabb[:, :3])
    half = np.einsum("nij,nj->ni", np.abs(rot), aabb[:, 3:])
    return (centre - half).min(axis=0), (centre + half).max(axis=0)


def far_enough(model: mujoco.MjModel, distance: float, radius: float) -> None:
    """Push the model's far clipping plane beyond the framed scene (``vis.map.zfar`` is a share
    of ``stat.extent``; a scene may keep it short for its depth sensors): for the viewer's own
    copy of the model, which only draws."""
    need = 1.5 * (distance + radius) / max(float(model.stat.extent), 1e-6)
    if model.vis.map.zfar < need:
        model.vis.map.zfar = need


def default_view(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, float, float, float]:
    """``(lookat (3,) m, distance m, azimuth deg, elevation deg)`` framing the scene's objects
    (``data`` after ``mj_forward``), with what ``simx:view`` says instead where it says it."""
    low, high = scene_box(model, data)
    lookat = (low + high) / 2
    radius = max(float(np.linalg.norm(high - low)) / 2, 0.1)
    fovy = math.radians(float(model.vis.global_.fovy))
    distance = MARGIN * radius / math.tan(fovy / 2)
    azimuth, elevation = AZIMUTH, ELEVATION
    own = scene_settings(model)
    try:
        if "lookat" in own:
            lookat = np.array([float(v) for v in own["lookat"].split(",")][:3])
        distance = float(own.get("distance", distance))
        azimuth = float(own.get("azimuth", azimuth))
        elevation = float(own.get("elevation", elevation))
    except ValueError:
        pass  # a malformed simx:view keeps the framing
    return lookat, distance, azimuth, elevation
