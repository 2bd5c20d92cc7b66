"""PyRep's ``Light``: on/off, diffuse and specular colours (RGB 0..1), spot parameters (rad)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class

_CASTS_SHADOWS = 8000  # sim_lightintparam_pov_casts_shadows
_SPOT_EXPONENT, _SPOT_CUTOFF = 8001, 8002  # sim_lightfloatparam_spot_exponent / spot_cutoff
_CONST_ATT, _LIN_ATT, _QUAD_ATT = 8003, 8004, 8005  # sim_lightfloatparam_*_attenuation


class Light(Object):
    """A light."""

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.LIGHT

    def _params(self) -> Any:
        return sim.call("getLightParameters", self._handle)

    def turn_on(self) -> None:
        sim.call("setLightParameters", self._handle, 1)

    def turn_off(self) -> None:
        sim.call("setLightParameters", self._handle, 0)

    def is_on(self) -> bool:
        return bool(self._params()[0] & 1)

    def is_off(self) -> bool:
        return not self.is_on()

    def get_diffuse(self) -> np.ndarray:
        """Diffuse colour (3,), 0..1."""
        return np.asarray(self._params()[2], dtype=np.float64)

    def set_diffuse(self, diffuse: Any) -> None:
        sim.call("setLightParameters", self._handle, int(self.is_on()), None, [float(v) for v in diffuse], None)

    def get_specular(self) -> np.ndarray:
        """Specular colour (3,), 0..1."""
        return np.asarray(self._params()[3], dtype=np.float64)

    def set_specular(self, specular: Any) -> None:
        sim.call("setLightParameters", self._handle, int(self.is_on()), None, None, [float(v) for v in specular])

    def get_intensity_properties(self) -> tuple[bool, float, float, float, float, float]:
        """``(cast_shadows, spot_exponent, spot_cutoff rad, constant, linear, quadratic attenuation)``."""
        f = [float(sim.call("getObjectFloatParam", self._handle, p))
             for p in (_SPOT_EXPONENT, _SPOT_CUTOFF, _CONST_ATT, _LIN_ATT, _QUAD_ATT)]
        shadows = bool(sim.call("getObjectInt32Param", self._handle, _CASTS_SHADOWS))
        return shadows, f[0], f[1], f[2], f[3], f[4]

    def set_intensity_properties(self, cast_shadows: Any = None, spot_exponent: Any = None, spot_cutoff: Any = None,
                                 const_atten_factor: Any = None, linear_atten_factor: Any = None,
                                 quad_atten_factor: Any = None) -> None:
        """Sets the given properties (the attenuation factors cannot be set, as in CoppeliaSim 4.1).

        Raises:
            Exception: an attenuation factor was given (PyRep's error).
        """
        if cast_shadows is not None:
            sim.call("setObjectInt32Param", self._handle, _CASTS_SHADOWS, int(cast_shadows))
        if spot_exponent is not None:
            if spot_exponent % 1 != 0:
                warnings.warn(f"spot exponent must be an integer, rounding {spot_exponent}", stacklevel=2)
            sim.call("setObjectFloatParam", self._handle, _SPOT_EXPONENT, float(round(spot_exponent)))
        if spot_cutoff is not None:
            if float(spot_cutoff) > np.pi / 2:  # PyRep warns, and sets it
                warnings.warn(f"Tried to set spot_cutoff to {spot_cutoff}, but the maximum allowed value is pi/2",
                              stacklevel=2)
            sim.call("setObjectFloatParam", self._handle, _SPOT_CUTOFF, float(spot_cutoff))
        if any(v is not None for v in (const_atten_factor, linear_atten_factor, quad_atten_factor)):
            raise Exception("CoppeliaSim currently does not support setting attenuation factors")


object_type_to_class[ObjectType.LIGHT] = Light
