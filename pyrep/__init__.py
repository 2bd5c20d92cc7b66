"""PyRep's interface on simx: code written for PyRep (CoppeliaSim 4.1) runs on MuJoCo, in this
process, headless. See docs/PYREP.md."""

__version__ = "4.1.0.3+simx"

testing = False

from pyrep.pyrep import PyRep  # noqa: E402

__all__ = ["PyRep", "testing"]
