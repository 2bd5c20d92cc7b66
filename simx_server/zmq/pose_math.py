"""CoppeliaSim 4.x's pose and matrix arithmetic (``sim.multiplyPoses``...): the facade's
:class:`~simx_server.scripts.facade_posemath.PoseMath`, which child scripts and ZMQ clients share;
kept here under its former name."""

from simx_server.scripts.facade_posemath import PoseMath

__all__ = ["PoseMath"]
