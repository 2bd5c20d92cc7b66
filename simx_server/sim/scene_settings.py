"""A scene's saved simulation settings: the ``simx:scene:simulation`` custom text.

::

    <custom>
      <text name="simx:scene:simulation" data="dt=0.01 real_time=0 real_time_factor=1"/>
    </custom>

``dt`` is the simulation step (s), ``real_time`` V-REP's real-time mode (1 on, 0 off: as fast as
possible) and ``real_time_factor`` its multiplier. The ``.ttt`` converter writes them from the
file's ``SIM`` records (:mod:`simx_server.scene.ttt.settings`, after CoppeliaSim's
``CSimulation::serialize``); any MJCF may declare them. ``simx-server``'s ``--dt`` and ``--speed``
win over them; without either the scene's values apply, else V-REP's default step (50 ms) and
simx's real-time pacing.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from simx_server.sim import friction, integrator
from simx_server.sim.objects import parse_settings, positive_setting, text_of

TEXT_NAME = "simx:scene:simulation"
DEFAULT_DT = 0.05  # s, V-REP's default simulation step


@dataclass(frozen=True)
class SceneSettings:
    """The settings a scene declares; None where it declares nothing.

    Attributes:
        dt: simulation step, s.
        real_time: V-REP's real-time mode.
        real_time_factor: its multiplier (simx's ``--speed`` when real time is on).
    """

    dt: float | None = None
    real_time: bool | None = None
    real_time_factor: float | None = None

    @property
    def speed(self) -> float | None:
        """The ``--speed`` these settings mean: the multiplier in real time, 0 (as fast as
        possible) when real time is off, None when the scene says nothing."""
        if self.real_time is None:
            return None
        return (self.real_time_factor or 1.0) if self.real_time else 0.0


def read(model: mujoco.MjModel, where: str) -> SceneSettings:
    """The ``simx:scene:simulation`` text of ``model``.

    Args:
        model: the compiled scene.
        where: the scene's file name, for errors.

    Returns:
        The settings (all None without the text).

    Raises:
        ValueError: an unknown key, or a value that is not a positive finite number (``dt``,
            ``real_time_factor``) or 0/1 (``real_time``); or a friction rule or integrator text
            simx cannot give (:func:`simx_server.sim.friction.declared`,
            :func:`simx_server.sim.integrator.declared`).
    """
    try:  # the scene's friction rule (sim/friction.py) and integrator (sim/integrator.py)
        friction.declared(model)
        integrator.declared(model)
    except ValueError as exc:
        raise ValueError(f"scene {where}: {exc}") from None
    raw = text_of(model, TEXT_NAME)
    if raw is None:
        return SceneSettings()
    try:
        items = parse_settings(raw)
        unknown = set(items) - {"dt", "real_time", "real_time_factor"}
        if unknown:
            raise ValueError(f"unknown keys {sorted(unknown)}; use dt=, real_time= and real_time_factor=")
        dt = positive_setting(items, "dt")
        factor = positive_setting(items, "real_time_factor")
        real_time = items.get("real_time")
        if real_time not in (None, "0", "1"):
            raise ValueError(f"real_time must be 0 or 1, got {real_time!r}")
    except ValueError as exc:
        raise ValueError(f"scene {where}: custom text {TEXT_NAME!r} ({raw!r}): {exc}") from None
    return SceneSettings(dt, None if real_time is None else real_time == "1", factor)
