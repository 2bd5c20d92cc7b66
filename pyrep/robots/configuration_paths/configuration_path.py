"""PyRep's ``ConfigurationPath``: the base of the paths robots follow."""


class ConfigurationPath:
    """A path in a robot's joint space."""

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
