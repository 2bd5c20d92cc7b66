"""simx-viewer: a live view of a running simx-server in MuJoCo's own viewer (issue 14).

This package needs MuJoCo (and a display); ``simx_client`` stays importable without it.

* :mod:`simx_viewer.link` -- the Zenoh side, no window: fetch the compiled model, follow the
  state stream (``ViewerLink``). Usable on its own, e.g. to record a run.
* :mod:`simx_viewer.app` -- the ``simx-viewer`` command: ``mujoco.viewer.launch_passive`` fed by
  a ``ViewerLink``.
"""

from simx_viewer.link import NoServerError, ViewerLink, ViewerModel, ViewerState

__all__ = ["NoServerError", "ViewerLink", "ViewerModel", "ViewerState"]
