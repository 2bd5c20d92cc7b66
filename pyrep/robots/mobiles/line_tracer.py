"""PyRep's ``LineTracer`` (robot_ttms/mobiles/LineTracer.ttm)."""

from pyrep.robots.mobiles.nonholonomic_base import NonHolonomicBase


class LineTracer(NonHolonomicBase):
    def __init__(self, count: int = 0):
        super().__init__(count, 2, "LineTracer")
