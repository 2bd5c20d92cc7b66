"""PyRep's ``HolonomicConfigurationPath``: a holonomic base (``HolonomicBase``) along a path."""

from __future__ import annotations

from pyrep.robots.configuration_paths.mobile_configuration_path import MobileConfigurationPath
from pyrep.robots.mobiles.mobile_base import box_adjusted_matrix_and_facing_angle


class HolonomicConfigurationPath(MobileConfigurationPath):
    """``step()`` sets the wheels for one simulation step: along a linear path the base's
    controller drives it to the goal; along a planned one its intermediate target moves from
    point to point (at least 1 cm on, once the base is within 0.1 m of it), turned so that the
    base faces it (PyRep's ``getBoxAdjustedMatrixAndFacingAngle``)."""

    def _turn_inter_target(self) -> None:
        inter = self._mobile.intermediate_target_base
        _, angle = box_adjusted_matrix_and_facing_angle(self._mobile, inter)
        inter.set_orientation([0.0, 0.0, angle])

    def _inter_actuation(self, reached: bool) -> list[float]:
        return [0.0, 0.0, 0.0] if reached else super()._inter_actuation(reached)
