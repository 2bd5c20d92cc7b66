"""PyRep's ``LoCoBot`` (robot_ttms/mobiles/LoCoBot.ttm, which this project's copy of PyRep's
models lacks): a differential-drive base. Without its model in the scene, making one raises
CoppeliaSimError (a RuntimeError, as PyRep's) naming the missing object."""

from pyrep.robots.mobiles.nonholonomic_base import NonHolonomicBase


class LoCoBot(NonHolonomicBase):
    def __init__(self, count: int = 0):
        super().__init__(count, 2, "LoCoBot")
