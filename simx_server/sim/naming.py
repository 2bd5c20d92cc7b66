"""V-REP names for MJCF elements: one global namespace made from MJCF's per-kind ones.

In V-REP every scene object has a name no other object has. MJCF names are unique only among
elements of one kind, so a body and a camera may both be called ``head`` (dm_control's dog), or
a body and its joint ``bthigh`` (dm_control's cheetah). simx gives every named joint, body,
site, camera and light a V-REP object, and names them by this rule:

* a name that one element alone has is its V-REP name, unchanged;
* a name that elements of several kinds share stays with one of them, by precedence
  **joint > body > site > camera > light** (whatever their places in the tree); the others get
  V-REP's own suffix for duplicates, ``NAME#0``, ``NAME#1``, ... in that same order, skipping
  any such name that an element of the scene already has.

So the dog's body ``head`` keeps ``head`` and its camera is ``head#0``; the cheetah's joint
``bthigh`` keeps ``bthigh`` and its body is ``bthigh#0``. ``simx:NAME`` custom texts address
the V-REP name. :func:`describe` makes the one log line that lists the renamed elements.
"""

from __future__ import annotations

import dataclasses

import mujoco

#: (kind, MuJoCo object type, count field of MjModel), in the order of precedence of the rule.
KINDS = (
    ("joint", mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
    ("body", mujoco.mjtObj.mjOBJ_BODY, "nbody"),
    ("site", mujoco.mjtObj.mjOBJ_SITE, "nsite"),
    ("camera", mujoco.mjtObj.mjOBJ_CAMERA, "ncam"),
    ("light", mujoco.mjtObj.mjOBJ_LIGHT, "nlight"),
)


@dataclasses.dataclass(frozen=True)
class Renamed:
    """An element whose V-REP name is not its MJCF name."""

    mj_name: str  # its name in the MJCF
    kind: str  # "joint", "body", "site", "camera" or "light"
    name: str  # its V-REP name, ``mj_name#N``


Identity = tuple[str, str]  # (kind, MJCF name): an element, across edits of the model


def vrep_names(model: mujoco.MjModel, previous: dict[Identity, str] | None = None
               ) -> tuple[dict[tuple[int, int], str], list[Renamed], dict[Identity, str]]:
    """V-REP names of the model's named joints, bodies (not the world), sites, cameras, lights.

    ``previous``: the identities and names of the model this one replaces (scene editing);
    an element still there keeps its V-REP name, so no object present changes name (nor, the
    registry keying handles by name, handle) when another one comes or goes. New elements are
    named by the module's rule, around the names kept.

    Returns ``(names, renamed, identities)``: ``names`` maps ``(int(mjtObj), id)`` to the
    element's V-REP name (unique across all of them; unnamed elements are absent); ``renamed``
    lists the elements whose V-REP name is not their MJCF name, by name then precedence;
    ``identities`` maps each element's ``(kind, MJCF name)`` to its V-REP name (the next
    call's ``previous``).

    Args:
        model: the compiled model.
        previous: see above.

    Returns:
        ``(names, renamed, identities)`` as said above.
    """
    previous = previous or {}
    shared: dict[str, list[tuple[str, int, int]]] = {}
    for kind, objtype, count in KINDS:
        for i in range(1 if kind == "body" else 0, getattr(model, count)):
            name = mujoco.mj_id2name(model, objtype, i)
            if name:
                shared.setdefault(name, []).append((kind, int(objtype), i))
    kept = {(kind, name) for name, elements in shared.items() for kind, _, _ in elements
            if (kind, name) in previous}
    kept_names = {previous[k] for k in kept}
    taken = set(shared) | kept_names
    identities: dict[Identity, str] = {}
    for name, elements in shared.items():
        plain_free = name not in kept_names
        n = 0
        for kind, _, _ in elements:
            if (kind, name) in kept:
                identities[(kind, name)] = previous[(kind, name)]
            elif plain_free:
                identities[(kind, name)] = name
                plain_free = False
            else:
                while f"{name}#{n}" in taken:
                    n += 1
                identities[(kind, name)] = f"{name}#{n}"
                taken.add(f"{name}#{n}")
    names = {(objtype, i): identities[(kind, name)]
             for name, elements in shared.items() for kind, objtype, i in elements}
    renamed = [Renamed(name, kind, identities[(kind, name)])
               for name, elements in shared.items() for kind, _, _ in elements
               if identities[(kind, name)] != name]
    return names, renamed, identities


def describe(scene: str, renamed: list[Renamed], limit: int) -> str:
    """The one WARNING line a scene load writes about its renamed elements: their count and the
    first ``limit`` of them (``'knee' body -> 'knee#0'``), then how many more; :func:`details`
    gives the DEBUG lines that name each one.

    Args:
        scene: the scene's file name.
        renamed: the renamed elements (``vrep_names``).
        limit: how many to name.

    Returns:
        The line.
    """
    items = [f"{r.mj_name!r} {r.kind} -> {r.name!r}" for r in renamed[:limit]]
    more = len(renamed) - limit
    if more > 0:
        items.append(f"and {more} more (--log-level DEBUG lists each)")
    return (f"scene {scene}: {len(renamed)} MJCF element(s) share a name with an element of another kind; "
            "V-REP names are global, so the name stays with the first of joint, body, site, camera, light "
            f"and the others are NAME#N: {', '.join(items)}")


def details(scene: str, renamed: list[Renamed]) -> list[str]:
    """One line per renamed element (logged at DEBUG level, after :func:`describe`'s summary).

    Args:
        scene: the scene's file name.
        renamed: the renamed elements.

    Returns:
        The lines.
    """
    return [f"scene {scene}: MJCF {r.kind} {r.mj_name!r} is the V-REP object {r.name!r}" for r in renamed]
