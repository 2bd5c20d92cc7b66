"""MuJoCo's ``implicit`` integrator while a body spins, ``implicitfast`` otherwise.

A converted ``.ttt`` scene (and PyRep's empty scene) steps with MuJoCo's ``implicit`` integrator:
its derivatives of the Coriolis and gyroscopic forces keep a spinning body's spin, where
``implicitfast``, which leaves them out, lets a fast spinner wobble ever faster (a wheeled robot
that fell off its floor spinning at 24 rad/s ended in a NaN; Bullet 2.78, CoppeliaSim 4.1's
default engine, applies no gyroscopic force at all). Those derivatives (MuJoCo's ``mjd_rne_vel``)
cost about 40 % of a step of RLBench's Panda (25 substeps of reach_target: 1.07 ms with
``implicit``, 0.63 ms with ``implicitfast``, MuJoCo 3.17), and matter only for a fast spinner:
under ``implicitfast`` at a 2 ms timestep, a body spinning at 3 rad/s kept its wobble over 30 s,
one at 6 rad/s grew it 1.4 times, at 10 rad/s twice, and at 24 rad/s it ended in a NaN.

A scene that declares ::

    <custom>
      <text name="simx:scene:integrator" data="implicitfast_below=0.01"/>
    </custom>

(the ``.ttt`` converter's scenes, PyRep's empty scene) steps with ``implicitfast`` while every
body turns by less than ``implicitfast_below`` radians per timestep about each world axis (0.01:
5 rad/s at 2 ms), and with ``implicit`` at each step that starts with a body turning faster
(:func:`choose`, before the step's substeps). Its MJCF keeps ``integrator="implicit"``, the safe
one where the text is not read. While a program has set another integrator
(``sim.setEngineInt32Param``: Euler or RK4), simx leaves it as it is.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from simx_server.sim.kept import PerObject
from simx_server.sim.objects import parse_settings, positive_setting, text_of

__all__ = ["TEXT", "choose", "declared"]

TEXT = "simx:scene:integrator"
_IMPLICIT = int(mujoco.mjtIntegrator.mjINT_IMPLICIT)
_FAST = int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST)


def declared(model: mujoco.MjModel) -> float | None:
    """The scene's ``implicitfast_below`` (rad per timestep), or None without the text.

    Args:
        model: the compiled scene.

    Returns:
        The bound, or None.

    Raises:
        ValueError: an unknown key, or a bound that is not a positive finite number (the scene
            is refused when it loads).
    """
    raw = text_of(model, TEXT)
    if raw is None:
        return None
    items = parse_settings(raw)
    if set(items) != {"implicitfast_below"}:
        raise ValueError(f"custom text {TEXT!r} ({raw[:80]!r}): give implicitfast_below= alone")
    try:
        return positive_setting(items, "implicitfast_below")
    except ValueError as exc:
        raise ValueError(f"custom text {TEXT!r}: {exc}") from None


def _bound(model: mujoco.MjModel) -> float | None:
    try:
        return declared(model)
    except ValueError:  # the scene's load refused it
        return None


#: ``model``'s :func:`declared` (None for a malformed text), read once.
_bounds: Callable[[mujoco.MjModel], float | None] = PerObject(_bound)


def choose(m: mujoco.MjModel, d: mujoco.MjData) -> None:
    """Set ``m``'s integrator for the next step (module docstring): ``implicit`` when a body of
    ``d`` turns by ``implicitfast_below`` radians per timestep or more about a world axis
    (``cvel``, of the world's last ``mj_forward``), else ``implicitfast``; nothing in a scene
    without the text, or while its integrator is neither.

    Args:
        m: the model (its ``opt.integrator`` is written).
        d: its data.
    """
    bound = _bounds(m)
    if bound is None:
        return
    opt = m.opt
    now = opt.integrator
    if now != _IMPLICIT and now != _FAST:
        return
    fastest = float(np.abs(d.cvel[:, :3]).max()) if m.nbody else 0.0  # rad/s, about x, y or z
    want = _IMPLICIT if fastest * opt.timestep >= bound else _FAST
    if want != now:
        opt.integrator = want
