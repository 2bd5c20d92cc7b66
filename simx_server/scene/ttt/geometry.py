"""Frame arithmetic for the converter: poses as (pos, quat w x y z), composed as V-REP does
(``parent ∘ local``)."""

from __future__ import annotations

import numpy as np

from simx_server.scene.ttt.model import Pose


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def mat_to_quat(m: np.ndarray) -> np.ndarray:
    """A rotation matrix (3, 3) as a unit quaternion w x y z."""
    t = np.trace(m)
    if t > 0:
        s = 2.0 * np.sqrt(t + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q / np.linalg.norm(q)


def compose(a: Pose, b: Pose) -> Pose:
    """``a ∘ b``: frame ``b`` given in frame ``a``, expressed in ``a``'s parent."""
    return Pose(a.pos + quat_to_mat(a.quat) @ b.pos, _unit(quat_mul(a.quat, b.quat)))


def inverse(a: Pose) -> Pose:
    qi = np.array([a.quat[0], -a.quat[1], -a.quat[2], -a.quat[3]])
    return Pose(-(quat_to_mat(qi) @ a.pos), qi)


def joint_displacement(joint_type: int, position: float, spherical_quat=None) -> Pose:
    """The motion of a joint at ``position``: a rotation about z (revolute, rad) or a
    translation along z (prismatic, m)."""
    if joint_type == 10:
        return Pose(np.zeros(3), np.array([np.cos(position / 2), 0, 0, np.sin(position / 2)]))
    if joint_type == 11:
        return Pose(np.array([0, 0, position]), np.array([1.0, 0, 0, 0]))
    return Pose()


def _unit(q: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(q)
    return q / n if n > 0 else np.array([1.0, 0, 0, 0])


def pose7(values: np.ndarray | None, quat_first: bool) -> Pose:
    """A 7-value frame: ``qw qx qy qz x y z`` (``Cfq``) or ``x y z qw qx qy qz`` (the others);
    identity for a missing one, a unit quaternion always."""
    if values is None:
        return Pose()
    if quat_first:
        q, p = values[:4], values[4:7]
    else:
        p, q = values[:3], values[3:7]
    norm = float(np.linalg.norm(q))
    q = q / norm if norm > 1e-9 and np.all(np.isfinite(q)) else np.array([1.0, 0, 0, 0])
    p = p if np.all(np.isfinite(p)) else np.zeros(3)
    return Pose(np.array(p, dtype=np.float64), np.array(q, dtype=np.float64))


def camera_quat(vrep_quat: np.ndarray) -> np.ndarray:
    """A V-REP vision sensor looks along its +z with +y up; a MuJoCo camera along its -z:
    turn by 180 degrees about y."""
    return quat_mul(vrep_quat, np.array([0.0, 0.0, 1.0, 0.0]))


#: V-REP's texture mappings (``Tob``) simx computes coordinates for: planar and cube.
TEXTURE_PLANE, TEXTURE_CUBE = 0, 3


def projected_uv(vertices: np.ndarray, faces: np.ndarray, frame: Pose, texture_frame: Pose, mode: int,
                 scale: tuple[float, float]) -> np.ndarray | None:
    """The texture coordinates V-REP computes for a texture the file keeps none for, one pair
    per triangle corner ((3 x M, 2)): the vertices (in the mesh frame ``frame``, given in the
    shape's frame) are taken into the texture's frame (``texture_frame``, in the shape's frame),
    and a texture of ``scale`` (m, x by y) centred on its origin is projected along its z
    (planar mapping), or per triangle along the texture frame's axis nearest to the triangle's
    normal (cube mapping). None for another mapping (cylinder, sphere) or unusable values."""
    sx, sy = scale
    if mode not in (TEXTURE_PLANE, TEXTURE_CUBE) or not (np.isfinite(sx) and np.isfinite(sy) and sx > 0 and sy > 0):
        return None
    if not len(faces):
        return None
    to_texture = compose(inverse(texture_frame), frame)
    pts = vertices @ quat_to_mat(to_texture.quat).T + to_texture.pos
    corners = pts[faces]  # (M, 3, 3)
    if mode == TEXTURE_PLANE:
        a, b = corners[..., 0], corners[..., 1]
    else:
        normal = np.abs(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
        axis = np.argmax(normal, axis=1)  # 0: seen along x, 1: y, 2: z
        first = np.where(axis == 0, 1, 0)  # the two other axes, in order
        second = np.where(axis == 2, 1, 2)
        rows = np.arange(len(faces))[:, None]
        a = corners[rows, np.arange(3)[None, :], first[:, None]]
        b = corners[rows, np.arange(3)[None, :], second[:, None]]
    uv = np.stack([a / sx + 0.5, b / sy + 0.5], axis=-1).reshape(-1, 2)
    return uv if np.all(np.isfinite(uv)) else None
