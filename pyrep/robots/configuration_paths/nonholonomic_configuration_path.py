"""PyRep's ``NonHolonomicConfigurationPath``: a differential-drive base (``NonHolonomicBase``)
along a path."""

from __future__ import annotations

import math

from pyrep.robots.configuration_paths.mobile_configuration_path import MobileConfigurationPath


class NonHolonomicConfigurationPath(MobileConfigurationPath):
    """``step()`` sets the wheels for one simulation step: along a linear path the base's PID
    controller steers it to the goal; along a planned one its intermediate target moves from
    point to point (at least 1 cm on, once the base is within 0.1 m of it)."""

    def step(self) -> bool:
        """One step of the base along the path; True once done (a planned path: once its last
        point is the target, the base then still on its way to it).

        Raises:
            RuntimeError: the path was completed already (``set_to_start`` runs it again).
        """
        if self._path_done:
            raise RuntimeError("This path has already been completed. If you want to re-run, then call set_to_start.")
        mobile = self._mobile
        pos_inter = mobile.intermediate_target_base.get_position(relative_to=mobile)
        if len(self._path_points) > 2:  # a planned path
            if self.inter_done:
                self._next_i_path()
                self._set_inter_target(self.i_path)
                self.inter_done = False
            if math.hypot(pos_inter[0], pos_inter[1]) < 0.1:
                self.inter_done = True
            actuation, _ = mobile.get_base_actuation()
            mobile.set_joint_target_velocities(actuation)
            if self.i_path == len(self._path_points) - 1:
                self._path_done = True
        else:
            actuation, self._path_done = mobile.get_base_actuation()
            mobile.set_joint_target_velocities(actuation)
        return self._path_done
