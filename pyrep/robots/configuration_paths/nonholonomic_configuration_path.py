"""PyRep's ``NonHolonomicConfigurationPath``: a differential-drive base (``NonHolonomicBase``)
along a path."""

from __future__ import annotations

from pyrep.robots.configuration_paths.mobile_configuration_path import MobileConfigurationPath


class NonHolonomicConfigurationPath(MobileConfigurationPath):
    """``step()`` sets the wheels for one simulation step: along a linear path the base's PID
    controller steers it to the goal; along a planned one its intermediate target moves from
    point to point (at least 1 cm on, once the base is within 0.1 m of it)."""
