"""What a scene or model file is, read from its content, whatever its name.

A program made for CoppeliaSim names its files as it likes: RLBench users copy their own scene
over ``task_design.ttt``, and ``PyRep.export_scene("x.ttt")`` on simx writes MJCF under that
name. So every place that opens a scene or model file (``PyRep.launch``/``import_model``,
``sim.loadScene``/``loadModel``, ``simxLoadScene``/``simxLoadModel``, the server's command line)
asks :func:`kind_of` and loads the file as what it holds:

* ``VREP``: a V-REP / CoppeliaSim ``.ttt``/``.ttm``: its first 4 bytes are ``VREP``
  (``SER_SIM_HEADER``, which coppeliaSimLib's ``CSer::_writeBinaryHeader`` writes and
  ``CSer::readOpenBinary`` checks: CoppeliaSim too tells a binary file by it, not its name);
* ``MJCF``: XML whose root element is ``<mujoco>``;
* ``URDF``: XML whose root element is ``<robot>``.

Anything else is a :class:`NotASceneFileError` that says what the file begins with. Only the
first bytes and the root element's start tag are read (the rest of the file is left to the
reader of its kind, and to :mod:`simx_server.base.scene_guard` first for a client's file).
"""

from __future__ import annotations

import enum
import xml.etree.ElementTree as ET
from pathlib import Path

from simx_server.base.arguments import quote

#: The magic of a V-REP / CoppeliaSim binary file (scene or model).
VREP_MAGIC = b"VREP"
#: XML root element -> kind.
_ROOTS = {"mujoco": "MJCF", "robot": "URDF"}


class FileKind(enum.Enum):
    """The kinds of scene and model files simx loads (value: how messages name it)."""

    MJCF = "MJCF"
    URDF = "URDF"
    VREP = "V-REP / CoppeliaSim"


class NotASceneFileError(ValueError):
    """A file whose content is none of :class:`FileKind` (the message names the file and what
    it begins with)."""


def is_vrep(path: str | Path) -> bool:
    """Whether ``path`` holds a V-REP / CoppeliaSim ``.ttt``/``.ttm`` (its ``VREP`` magic),
    whatever its name. False for a file that cannot be read (its loader says why).

    Args:
        path: a file.
    """
    try:
        with open(path, "rb") as f:
            return f.read(len(VREP_MAGIC)) == VREP_MAGIC
    except OSError:
        return False


def kind_of(path: str | Path) -> FileKind:
    """The kind of the scene or model file ``path``, from its content (module docstring).

    Args:
        path: a file.

    Returns:
        Its kind.

    Raises:
        NotASceneFileError: the content is neither a V-REP / CoppeliaSim file nor XML whose
            root is ``<mujoco>`` or ``<robot>``.
        OSError: the file cannot be read.
    """
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(64)
    if head.startswith(VREP_MAGIC):
        return FileKind.VREP
    root = _root_element(path)
    if root in _ROOTS:
        return FileKind[_ROOTS[root]]
    what = (f"XML whose root element is <{root}>" if root is not None
            else f"not XML (it begins with {quote(head[:16])})" if head.strip() else "empty")
    raise NotASceneFileError(f"{path.name}: not a scene or model file: {what}; simx loads MJCF (root <mujoco>), "
                             "URDF (root <robot>) and V-REP / CoppeliaSim .ttt/.ttm files, whatever their names")


def _root_element(path: Path) -> str | None:
    """The local name of the root element (namespace dropped, as MuJoCo ignores it), or None
    for a file that is not well-formed XML up to that tag."""
    try:
        for _, el in ET.iterparse(str(path), events=("start",)):
            return el.tag.rsplit("}", 1)[-1] if isinstance(el.tag, str) else None
    except (ET.ParseError, LookupError, ValueError, OSError):
        return None
    return None
