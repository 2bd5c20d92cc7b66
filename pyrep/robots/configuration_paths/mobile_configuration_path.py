"""PyRep's ``MobileConfigurationPath``: 2-D poses a mobile base follows, driven by its own
controller (``get_base_actuation``) towards the base's intermediate target dummy, moved along
the path's points; ``step()`` sets the wheels' velocities for one simulation step (the caller
steps the simulation, as in PyRep).

The points are ``[x (m), y (m), yaw (rad)]`` (two for a linear path: the start and the goal), or
``[x, y, yaw, distance from the previous point (m)]`` (a planned path).
"""

from __future__ import annotations

import math
from typing import Any

from pyrep.backend import sim
from pyrep.robots.configuration_paths.configuration_path import ConfigurationPath


class MobileConfigurationPath(ConfigurationPath):
    """A mobile base's path; made by the base's ``get_linear_path`` / ``get_nonlinear_path``,
    it puts the base at its start (``set_to_start``) as PyRep's does."""

    def __init__(self, mobile: Any, path_points: list[list[float]]):
        self._bind_world()
        self._mobile = mobile
        self._path_points = path_points
        self._drawing_handle: int | None = None
        self._path_done = False
        self.i_path = -1
        self.inter_done = True
        self.set_to_start()
        if len(self._path_points) > 2:
            self._set_inter_target(0)

    def step(self) -> bool:
        """One step of the base along the path: sets the wheels' velocities for one simulation
        step; True once done (a planned path: once its last point is the target, the base then
        still on its way to it).

        Raises:
            RuntimeError: the path was completed already (``set_to_start`` runs it again).
        """
        if self._path_done:
            raise RuntimeError("This path has already been completed. If you want to re-run, then call set_to_start.")
        mobile = self._mobile
        if len(self._path_points) <= 2:  # a linear path: the base's controller to the goal
            actuation, self._path_done = mobile.get_base_actuation()
        else:  # a planned path
            pos_inter = mobile.intermediate_target_base.get_position(relative_to=mobile)
            if self.inter_done:
                self._next_i_path()
                self._set_inter_target(self.i_path)
                self._turn_inter_target()
            self.inter_done = math.hypot(pos_inter[0], pos_inter[1]) < 0.1
            actuation = self._inter_actuation(self.inter_done)
            self._path_done = self.i_path == len(self._path_points) - 1
        mobile.set_base_angular_velocites(actuation)
        return self._path_done

    def _turn_inter_target(self) -> None:
        """The intermediate target just moved to a new point (a subclass may turn it)."""

    def _inter_actuation(self, reached: bool) -> list[float]:
        """The wheels' velocities towards the intermediate target (``reached``: within 0.1 m)."""
        return self._mobile.get_base_actuation()[0]

    def set_to_start(self) -> None:
        """Places the base at the path's first pose (``set_2d_pose``)."""
        self._mobile.set_2d_pose(self._path_points[0][:3])
        self._path_done = False

    def set_to_end(self) -> None:
        """Places the base at the path's last pose (``set_2d_pose``)."""
        self._mobile.set_2d_pose(self._path_points[-1][:3])

    def visualize(self) -> None:
        """A drawing object of lines through the base's positions along the path (CoppeliaSim's
        ``sim.addDrawingObject``: simx keeps it as data, headless; the base is not moved to
        read them: each is the pose's x, y at the base's height).

        Raises:
            RuntimeError: the path has no points.
        """
        if len(self._path_points) <= 0:
            raise RuntimeError("Can't visualise a path with no points.")
        if self._drawing_handle is None:
            self._drawing_handle = int(sim.call("addDrawingObject", sim.sim_drawing_lines, 3, 0, -1, 99999,  # type: ignore[attr-defined]
                                                [1.0, 0.0, 1.0]))
        sim.call("addDrawingObjectItem", self._drawing_handle, None)
        z = float(self._mobile.z_pos)
        prev = [float(self._path_points[0][0]), float(self._path_points[0][1]), z]
        for point in self._path_points:
            p = [float(point[0]), float(point[1]), z]
            sim.call("addDrawingObjectItem", self._drawing_handle, prev + p)
            prev = p

    def clear_visualization(self) -> None:
        """Empties the drawing object of :meth:`visualize`."""
        if self._drawing_handle is not None:
            sim.call("addDrawingObjectItem", self._drawing_handle, None)

    def _next_i_path(self) -> None:
        """Moves on along the points by at least 1 cm (or to the last one)."""
        travelled = 0.0
        while travelled < 0.01:
            self.i_path += 1
            if self.i_path >= len(self._path_points) - 1:
                self.i_path = len(self._path_points) - 1
                break
            travelled += self._path_points[self.i_path][-1]

    def _set_inter_target(self, i: int) -> None:
        """Puts the base's intermediate target dummy at point ``i``."""
        point = self._path_points[i]
        self._mobile.intermediate_target_base.set_position([point[0], point[1], self._mobile.target_z])
        self._mobile.intermediate_target_base.set_orientation([0.0, 0.0, point[2]])
