"""What scripts and clients changed in the live MuJoCo model, carried over to the model an edit
compiles (:meth:`simx_server.scene.editor.Editor._edit`): V-REP edits its scene in place, so a
dummy created and placed before ``sim.createOctree`` is still where it was put afterwards
(V-REP's ``complexCommandTest``), and so are colours, sizes, limits and view angles.

Poses are the editor's own (``_runtime_placements``, which also checks the parent); this module
keeps the other per-element fields that commands write into ``MjModel``: for each field, the
elements whose value differs from the model as it was compiled are found by name (geoms, often
unnamed, by their body's name and their rank in it) and copied into the new model.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.sim import shape_dynamics, shape_looks

#: Named elements' fields that commands change at run time (element kind -> model fields).
FIELDS = {
    mujoco.mjtObj.mjOBJ_BODY: ("body_mass", "body_inertia", "body_ipos", "body_iquat"),
    mujoco.mjtObj.mjOBJ_SITE: ("site_size", "site_rgba"),
    mujoco.mjtObj.mjOBJ_CAMERA: ("cam_fovy",),
    mujoco.mjtObj.mjOBJ_LIGHT: ("light_diffuse", "light_specular", "light_ambient", "light_active"),
    mujoco.mjtObj.mjOBJ_JOINT: ("jnt_range", "jnt_pos", "jnt_axis", "jnt_stiffness"),
}
#: Geoms' fields (``geom_matid`` only where a command dropped the material: -1).
GEOM_FIELDS = ("geom_rgba", "geom_size", "geom_friction", "geom_contype", "geom_conaffinity", "geom_matid")
#: The geoms' contact bits (``sim_shapeintparam_respondable``), written into the spec an edit
#: compiles (:meth:`simx_server.scene.editor.Editor._edit`).
CONTACT_FIELDS = ("geom_contype", "geom_conaffinity")
#: A geom's specular and emission colours and shininess that commands set (not model fields:
#: :mod:`simx_server.sim.shape_looks`), kept as if they were one.
LOOKS = "shape_looks"


def _fields(model: mujoco.MjModel) -> list[str]:
    every = [f for fields in FIELDS.values() for f in fields] + list(GEOM_FIELDS)
    return [f for f in every if hasattr(model, f)]


def snapshot(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Copies of the kept fields of a model as compiled (the baseline of :func:`changes`).

    Args:
        model: a freshly compiled model.

    Returns:
        Field name -> array copy.
    """
    return {f: getattr(model, f).copy() for f in _fields(model)}


def _differs(now: np.ndarray, base: np.ndarray) -> np.ndarray:
    diff = now != base
    return diff.reshape(len(diff), max(1, int(np.prod(diff.shape[1:])))).any(axis=1) if diff.ndim > 1 else diff


def _geom_key(m: mujoco.MjModel, g: int) -> tuple[str, int] | None:
    body = int(m.geom_bodyid[g])
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body)
    if not name:
        return None
    return name, g - int(m.body_geomadr[body])


def changes(model: mujoco.MjModel, baseline: dict[str, np.ndarray] | None) -> list[tuple]:
    """What differs in ``model`` from ``baseline``: ``(field, key, value)`` with key an element
    name, or ``(body name, rank)`` for a geom. Empty when the baseline does not describe this
    model (another element count).

    Args:
        model: the live model.
        baseline: :func:`snapshot` of it as compiled, or None.

    Returns:
        The changes, values copied.
    """
    if not baseline:
        return []
    out = []
    for objtype, fields in FIELDS.items():
        for f in fields:
            if f not in baseline or getattr(model, f).shape != baseline[f].shape:
                continue
            now = getattr(model, f)
            for i in np.flatnonzero(_differs(now, baseline[f])):
                name = mujoco.mj_id2name(model, objtype, int(i))
                if name:
                    out.append((f, name, now[i].copy()))
    for f in GEOM_FIELDS:
        if f not in baseline or getattr(model, f).shape != baseline[f].shape:
            continue
        now = getattr(model, f)
        for g in np.flatnonzero(_differs(now, baseline[f])):
            if f == "geom_matid" and now[g] != -1:
                continue  # material ids are the old model's
            key = _geom_key(model, int(g))
            if key is not None:
                out.append((f, key, now[g].copy()))
    looks = shape_looks.of(model)
    for g in np.flatnonzero(looks.kept()) if looks is not None else ():
        key = _geom_key(model, int(g))
        if key is not None:
            out.append((LOOKS, key, shape_looks.entry(looks, int(g))))
    return out


def renamed(kept: list[tuple], names: dict[str, str]) -> list[tuple]:
    """:func:`changes` with the elements an edit renamed under their new names (a geom's key
    follows its body's).

    Args:
        kept: the changes taken from the old model.
        names: old name -> new name.

    Returns:
        The changes, keyed by the new names.
    """
    if not names:
        return kept
    return [(f, (names.get(key[0], key[0]), key[1]) if isinstance(key, tuple) else names.get(key, key), value)
            for f, key, value in kept]


def restore(model: mujoco.MjModel, kept: list[tuple], skip: set[str] = frozenset()) -> bool:
    """Write :func:`changes` into a new model where the element is still there (same name; a
    geom: same body and rank, same type), except for elements named in ``skip`` (those the edit
    itself set). A geom's fields are its shape's own, never set by an edit that places its
    body (a re-parented shape keeps its contact bits, colour and friction), so ``skip`` leaves
    them.

    Args:
        model: the newly compiled model.
        kept: the changes taken from the old one.
        skip: element names to leave as compiled.

    Returns:
        Whether a body's mass or inertia changed (then ``mj_setConst`` is due).
    """
    kinds = {f: objtype for objtype, fields in FIELDS.items() for f in fields}
    inertial = False
    for f, key, value in kept:
        if isinstance(key, tuple):
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, key[0])
            if body < 0 or key[1] >= model.body_geomnum[body]:
                continue
            i = int(model.body_geomadr[body]) + key[1]
            if f == LOOKS:
                shape_looks.put(model, i, value)
                continue
        else:
            if key in skip:
                continue
            i = mujoco.mj_name2id(model, kinds[f], key)
            if i < 0:
                continue
        getattr(model, f)[i] = value
        inertial |= f.startswith("body_")
    if any(f in ("geom_contype", "geom_conaffinity") for f, _, _ in kept):
        shape_dynamics.body_contact_bits(model)
    return inertial


def settle(world: Any) -> None:
    """After masses or inertias changed: MuJoCo's derived constants again, the state kept.

    Args:
        world: the :class:`~simx_server.sim.world.World`.
    """
    m, d = world.model, world.data
    saved = d.qpos.copy(), d.qvel.copy(), d.act.copy(), d.time
    mujoco.mj_setConst(m, d)
    d.qpos[:], d.qvel[:], d.act[:] = saved[:3]
    d.time = saved[3]
    mujoco.mj_forward(m, d)


#: How a kept field is written into an MjSpec element (``sim.saveScene``): field -> attribute.
_SPEC_ATTRIBUTES = {
    "body_mass": "mass", "body_inertia": "inertia", "body_ipos": "ipos", "body_iquat": "iquat",
    "site_size": "size", "site_rgba": "rgba", "cam_fovy": "fovy",
    "light_diffuse": "diffuse", "light_specular": "specular", "light_ambient": "ambient", "light_active": "active",
    "jnt_range": "range", "jnt_pos": "pos", "jnt_axis": "axis", "jnt_stiffness": "stiffness",
    "geom_rgba": "rgba", "geom_size": "size", "geom_friction": "friction",
    "geom_contype": "contype", "geom_conaffinity": "conaffinity",
}
_SPEC_FINDERS = {"body": "body", "site": "site", "cam": "camera", "light": "light", "jnt": "joint"}


def write(spec: mujoco.MjSpec, kept: list[tuple]) -> None:
    """Write :func:`changes` into ``spec``, so that a saved scene (``sim.saveScene``, PyRep's
    ``export_scene``) has the colours, sizes, masses, contact flags... that commands gave its
    objects at run time, as CoppeliaSim saves its scene as it is. A mesh geom's size is its
    mesh's (not written); a geom that lost its material (``geom_matid`` -1) is written without.

    Args:
        spec: the spec to save (a copy of the live one).
        kept: the live model's changes.
    """
    for f, key, value in kept:
        if isinstance(key, tuple):
            body = spec.body(key[0])
            geoms = list(body.geoms) if body is not None else []
            if key[1] >= len(geoms):
                continue
            el = geoms[key[1]]
            if f == "geom_matid":
                el.material = ""
                continue
            if f == "geom_size" and el.type == mujoco.mjtGeom.mjGEOM_MESH:
                continue
        else:
            el = getattr(spec, _SPEC_FINDERS[f.split("_", 1)[0]])(key)
            if el is None:
                continue
            if f.startswith("body_"):
                el.explicitinertial = True
        attribute = _SPEC_ATTRIBUTES.get(f)
        if attribute is not None:
            current = getattr(el, attribute)
            setattr(el, attribute, type(current)(value) if np.ndim(value) == 0 else np.asarray(value, dtype=float))
