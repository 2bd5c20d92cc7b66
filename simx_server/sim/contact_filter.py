"""Per-pair contact decisions inside MuJoCo's collision detection (``mjcb_contactfilter``).

MuJoCo calls one process-wide contact filter for every geom pair that passes its broad phase
(bounding boxes overlap) and is not an explicit ``<pair>``; when a filter is installed it replaces
MuJoCo's own geom-level test (``contype`` / ``conaffinity``), while the body-level tests (same
weld body, parent-child, ``<exclude>``) still run before it. :class:`ContactFilter` gives one
``MjData`` its own decisions and leaves every other ``MjData`` of the process with MuJoCo's
default:

* :meth:`ContactFilter.candidates` runs MuJoCo's broad phase at the data's current positions and
  returns the geom pairs that would go on to the narrow phase (the filter records them instead of
  deciding), without changing the state the next ``mj_step`` starts from;
* :meth:`ContactFilter.set_discarded` sets the pairs to drop; until the next call, every
  collision detection on that data (``mj_step``, ``mj_forward``) drops exactly those.

No Python code other than a set lookup runs inside MuJoCo: whatever decides (a script's
``sysCall_contactCallback``) runs between the two calls, outside the engine, where it may read or
change the scene like any other script code.
"""

from __future__ import annotations

import threading

import mujoco

_lock = threading.Lock()
_active: list[ContactFilter] = []  # at most a few: one per world with a deciding script


def default_discards(m: mujoco.MjModel, g1: int, g2: int) -> bool:
    """MuJoCo's own geom-level filter: discard unless ``contype`` of one geom shares a bit with
    ``conaffinity`` of the other (``filterBitmask`` in MuJoCo's collision driver).

    Args:
        m: the MuJoCo model.
        g1: a geom id.
        g2: another geom id.

    Returns:
        True when MuJoCo would not collide the pair.
    """
    return not (int(m.geom_contype[g1]) & int(m.geom_conaffinity[g2])) and not (
        int(m.geom_contype[g2]) & int(m.geom_conaffinity[g1]))


def _filter(m: mujoco.MjModel, d: mujoco.MjData, g1: int, g2: int) -> int:
    """The installed ``mjcb_contactfilter``: 1 drops the pair, 0 lets MuJoCo collide it."""
    try:
        if default_discards(m, g1, g2):
            return 1
        for f in _active:
            if f.data is d:
                pair = (g1, g2) if g1 < g2 else (g2, g1)
                if f._recording is not None:
                    f._recording.add(pair)
                    return 0
                return 1 if pair in f._discarded else 0
        return 0
    except Exception:  # an exception must not cross into MuJoCo's C code: keep MuJoCo's default
        return 0


class ContactFilter:
    """Contact decisions for one ``MjData`` (see the module's docstring); :meth:`close` removes
    them. Used on the thread that steps ``data``.

    Args:
        data: the ``MjData`` the decisions apply to (other data keep MuJoCo's default filter).
    """

    def __init__(self, data: mujoco.MjData):
        self.data = data
        self._recording: set[tuple[int, int]] | None = None
        self._discarded: frozenset[tuple[int, int]] = frozenset()
        with _lock:
            _active.append(self)
            if len(_active) == 1:
                mujoco.set_mjcb_contactfilter(_filter)

    def candidates(self, m: mujoco.MjModel) -> set[tuple[int, int]]:
        """The geom pairs ``(g1, g2)``, ``g1 < g2``, that MuJoCo's broad phase and geom bitmasks
        let through at the data's current positions (explicit ``<pair>`` elements excepted).
        Runs ``mj_kinematics`` and ``mj_collision`` on the data: its contacts are recomputed
        by the next ``mj_step`` or ``mj_forward``, which start from ``qpos`` and ``qvel``.

        Args:
            m: the MuJoCo model of the filter's data.

        Returns:
            Set of ``(g1, g2)`` geom id pairs.
        """
        self._recording = set()
        try:
            mujoco.mj_kinematics(m, self.data)
            mujoco.mj_collision(m, self.data)
            return self._recording
        finally:
            self._recording = None

    def set_discarded(self, pairs: set[tuple[int, int]]) -> None:
        """Drop these geom pairs (``g1 < g2``) in every collision detection on the data until
        the next call.

        Args:
            pairs: ``(g1, g2)`` geom id pairs with ``g1 < g2``.
        """
        self._discarded = frozenset(pairs)

    def close(self) -> None:
        """Remove the decisions; the process-wide filter goes when no data has any."""
        with _lock:
            if self in _active:
                _active.remove(self)
            if not _active:
                mujoco.set_mjcb_contactfilter(None)
