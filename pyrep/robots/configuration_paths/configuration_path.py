"""PyRep's ``ConfigurationPath``: the base of the paths robots follow."""

from pyrep.backend import sim


class ConfigurationPath(sim.OnItsWorld):
    """A path in a robot's joint space, followed in the world of the PyRep current when it is
    made (:class:`pyrep.backend.sim.OnItsWorld`)."""

    def step(self) -> bool:
        raise NotImplementedError()

    def set_to_start(self) -> None:
        raise NotImplementedError()

    def set_to_end(self) -> None:
        raise NotImplementedError()

    def visualize(self) -> None:
        raise NotImplementedError()

    def clear_visualization(self) -> None:
        raise NotImplementedError()
