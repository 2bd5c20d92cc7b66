"""PyRep's ``HolonomicConfigurationPath``: a holonomic base (``HolonomicBase``) along a path."""

from __future__ import annotations

import math

from pyrep.robots.configuration_paths.mobile_configuration_path import MobileConfigurationPath
from pyrep.robots.mobiles.mobile_base import box_adjusted_matrix_and_facing_angle


class HolonomicConfigurationPath(MobileConfigurationPath):
    """``step()`` sets the wheels for one simulation step: along a linear path the base's
    controller drives it to the goal; along a planned one its intermediate target moves from
    point to point (at least 1 cm on, once the base is within 0.1 m of it), turned so that the
    base faces it (PyRep's ``getBoxAdjustedMatrixAndFacingAngle``)."""

    def step(self) -> bool:
        """One step of the base along the path; True once done (a planned path: once its last
        point is the target, the base then still on its way to it).

        Raises:
            RuntimeError: the path was completed already (``set_to_start`` runs it again).
        """
        if self._path_done:
            raise RuntimeError("This path has already been completed. If you want to re-run, then call set_to_start.")
        mobile = self._mobile
        inter = mobile.intermediate_target_base
        pos_inter = inter.get_position(relative_to=mobile)
        if len(self._path_points) > 2:  # a planned path
            if self.inter_done:
                self._next_i_path()
                self._set_inter_target(self.i_path)
                self.inter_done = False
                m, angle = box_adjusted_matrix_and_facing_angle(mobile, inter)
                inter.set_position([m[3], m[7], mobile.target_z])
                inter.set_orientation([0.0, 0.0, angle])
            if math.hypot(pos_inter[0], pos_inter[1]) < 0.1:
                self.inter_done = True
                actuation = [0.0, 0.0, 0.0]
            else:
                actuation, _ = mobile.get_base_actuation()
            mobile.set_base_angular_velocites(actuation)
            if self.i_path == len(self._path_points) - 1:
                self._path_done = True
        else:
            actuation, self._path_done = mobile.get_base_actuation()
            mobile.set_base_angular_velocites(actuation)
        return self._path_done
