"""CoppeliaSim 4.x's sensors created at run time: ``sim.createVisionSensor`` (a MuJoCo camera) and
``sim.createProximitySensor`` (a site carrying a ``rangefinder``), added to the scene's MjSpec and
recompiled as the scene editor does for ``sim.createDummy``. Each appears at the world origin with
CoppeliaSim's orientation (looking along the world's +z); its settings (near/far clipping, a cone's
angle) go into its ``simx:`` custom text, as in a scene file (docs/SCENES.md).
"""

from __future__ import annotations

import math
from typing import Any

import mujoco

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim.spec_tools import _names, vrep_suffix
from simx_server.sim.physics import check_resolution

PROXIMITY_CONE, PROXIMITY_RAY = 33, 34


def _numbers(values: Any, n: int, what: str, integer: bool = False) -> list:
    if not isinstance(values, (list, tuple)) or len(values) < n:
        raise ArgumentError(f"{what} must hold {n} numbers")
    return [(_int if integer else _num)(v, f"{what}[i]") for v in values[:n]]


# Run-time creation of vision and proximity sensors.

def _create(ctx: CallContext, what: str, base: str, build) -> int:
    sim = ctx.simulation(what)

    def change(spec: mujoco.MjSpec):
        name = base + vrep_suffix({base}, _names(spec) | set(sim.world.by_name))
        build(spec, name)
        return lambda: sim.world.resolve(name).handle

    return sim.editor._edit(change)


@sim_function("createVisionSensor")
def createVisionSensor(ctx: CallContext, options: Any, intParams: Any, floatParams: Any) -> int:  # noqa: N802, N803
    """A new vision sensor (a MuJoCo camera) at the world origin looking along +z; its handle.
    ``options`` bit 0: perspective (else orthographic); ``intParams`` resolution x, y (and 2
    reserved); ``floatParams`` near and far clipping (m), the view angle (rad, perspective)
    or the orthographic size (m), then the body size and null-pixel colour (no meaning for a
    MuJoCo camera). Errors: a bad resolution, near not in (0, far).

    ``sim.createVisionSensor``.

    Args:
        options: bit 0: perspective.
        intParams: at least 2 integers (pixels).
        floatParams: at least 3 numbers (m, m, rad or m).

    Returns:
        The sensor's handle.

    Raises:
        ArgumentError: a bad resolution or clipping planes.
        UnsupportedError: no simulation behind the script.
    """
    opts = _int(options, "options")
    ints = _numbers(intParams, 2, "intParams", integer=True)
    floats = _numbers(floatParams, 3, "floatParams")
    w, h = ints[:2]
    check_resolution(w, h, "createVisionSensor")
    near, far, view = floats[:3]
    if not 0 < near < far:
        raise ArgumentError("floatParams: near clipping must lie in (0, far)")
    if not view > 0 or (opts & 1 and view >= math.pi):
        raise ArgumentError("floatParams[3]: the view angle must lie in (0, pi) rad, an orthographic size above 0")

    def build(spec: mujoco.MjSpec, name: str) -> None:
        cam = spec.worldbody.add_camera(name=name, quat=[0, 0, 1, 0], resolution=[w, h])  # MuJoCo looks along -z
        # V-REP's angle and size span the larger side; MuJoCo's fovy the vertical one
        if opts & 1:
            half = view / 2 if h >= w else math.atan(math.tan(view / 2) * h / w)
            cam.fovy = math.degrees(2 * half)
        else:
            cam.proj = mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC
            cam.fovy = view * min(h / w, 1.0)  # an orthographic camera's fovy is its view height (m)
        spec.add_text(name=f"simx:{name}", data=f"near={near} far={far}")

    return _create(ctx, "createVisionSensor", "Vision_sensor", build)


@sim_function("createProximitySensor")
def createProximitySensor(ctx: CallContext, sensorType: Any, subType: Any, options: Any, intParams: Any,  # noqa: N802, N803
                          floatParams: Any) -> int:  # noqa: N803
    """A new proximity sensor at the world origin, detecting along +z; its handle.
    ``sensorType`` ``sim.proximitysensor_ray`` (34: one ray, a rangefinder) or
    ``sim.proximitysensor_cone`` (33: a fan of rays filling the cone); ``floatParams`` offset
    (m: where a ray starts along +z, or the cone's apex; nothing nearer is seen), range (m, from
    there on), and for a cone its radius (m, index 7: it sees from that far from its apex on,
    out to radius + range) and angle (rad, index 9), as CoppeliaSim's ``CConvexVolume``.
    Pyramid, cylinder and disc volumes: UnsupportedError (MuJoCo casts rays).

    ``sim.createProximitySensor``.

    Args:
        sensorType: 33 or 34.
        subType: checked.
        options: checked.
        intParams: integers (checked).
        floatParams: numbers (m, rad).

    Returns:
        The sensor's handle.

    Raises:
        UnsupportedError: another volume type, or no simulation behind the script.
        ArgumentError: bad parameters (a range that is not positive, an offset or radius
            beyond 1000 m, a negative radius).
    """
    kind = _int(sensorType, "sensorType")
    _int(subType, "subType")
    _int(options, "options")
    _numbers(intParams, 0, "intParams", integer=True)
    if kind not in (PROXIMITY_RAY, PROXIMITY_CONE):
        raise UnsupportedError(f"createProximitySensor type {kind}: simx makes ray (34) and cone (33) sensors "
                               "(MuJoCo casts rays, it has no detection volumes)")
    floats = _numbers(floatParams, 10 if kind == PROXIMITY_CONE else 2, "floatParams")
    offset, reach = floats[:2]
    near = floats[7] if kind == PROXIMITY_CONE else 0.0  # a cone's radius: it sees from there on
    if not -1000 <= offset <= 1000:
        raise ArgumentError("floatParams[1]: the offset must lie in [-1000, 1000] m")
    if not 0 <= near <= 1000:
        raise ArgumentError("floatParams[8]: the cone's radius must lie in [0, 1000] m")
    if not 0 < reach <= 1e4 or offset + near + reach <= 0:
        raise ArgumentError("floatParams[2]: the range must lie in (0, 10000] m and end ahead of the sensor")
    angle = math.degrees(floats[9]) if kind == PROXIMITY_CONE else 0.0
    if kind == PROXIMITY_CONE and not 0 < angle < 180:
        raise ArgumentError("floatParams[10]: the cone's angle must lie in (0, pi) rad")

    def build(spec: mujoco.MjSpec, name: str) -> None:
        spec.worldbody.add_site(name=name, size=[0.005, 0.005, 0.005])
        # parse an MJCF rangefinder: MuJoCo's defaults (its data spec included), then the site and cutoff
        ref = mujoco.MjSpec.from_string('<mujoco><worldbody><site name="s"/></worldbody>'
                                        '<sensor><rangefinder site="s"/></sensor></mujoco>').sensors[0]
        spec.add_sensor(name=f"{name}_range", type=ref.type, objtype=ref.objtype, objname=name,
                        cutoff=offset + near + reach, intprm=list(ref.intprm))
        # the ray starts at the offset, the cone's apex lies there (proximity.axis_offset)
        items = ([f"angle={angle}"] if kind == PROXIMITY_CONE else []) + ([f"offset={offset!r}"] if offset else [])
        items += [f"radius={near!r}"] if near > 0 else []
        if items:
            spec.add_text(name=f"simx:{name}", data=" ".join(items))

    return _create(ctx, "createProximitySensor", "Proximity_sensor", build)




@sim_function("createForceSensor")
def createForceSensor(ctx: CallContext, options: Any, intParams: Any, floatParams: Any, color: Any = None) -> int:  # noqa: N802, N803
    """A new force sensor at the world origin: a site with MuJoCo force and torque sensors, the
    ``vrep_parent=-1`` setting (V-REP's tree decides what it measures); its handle.
    ``floatParams[0]`` is its size (m); CoppeliaSim's filter and breaking thresholds
    (``intParams``, the other ``floatParams``) are checked only. As CoppeliaSim's, it reads what
    hangs below it: nothing (result 0) until an object is hung from it (``sim.setObjectParent(obj,
    sensor)``, a dynamic shape held by a weld), then the force and torque that object exerts on
    the sensor's parent, in the sensor's frame (:mod:`simx_server.sim.force_sensors`).

    ``sim.createForceSensor``.

    Args:
        options: checked.
        intParams: at least 5 integers (checked).
        floatParams: at least 1 number: the size (m, > 0).
        color: ignored (None or colours).

    Returns:
        The sensor's handle.

    Raises:
        ArgumentError: a size that is not positive, malformed parameters.
        UnsupportedError: no simulation behind the script.
    """
    _int(options, "options")
    _numbers(intParams, 5, "intParams", integer=True)
    size = _numbers(floatParams, 1, "floatParams")[0]
    if not size > 0:
        raise ArgumentError("floatParams[0]: the sensor's size must be > 0 (m)")

    def build(spec: mujoco.MjSpec, name: str) -> None:
        spec.worldbody.add_site(name=name, size=[size / 2, size / 2, size / 2], type=mujoco.mjtGeom.mjGEOM_CYLINDER)
        for kind, suffix in ((mujoco.mjtSensor.mjSENS_FORCE, "force"), (mujoco.mjtSensor.mjSENS_TORQUE, "torque")):
            spec.add_sensor(name=f"{name}_{suffix}", type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=name)
        spec.add_text(name=f"simx:{name}", data="vrep_parent=-1")

    return _create(ctx, "createForceSensor", "Force_sensor", build)
