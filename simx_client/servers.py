"""Local simx-servers for a client program: the one place ``simx_client`` reaches the server side.

The client package talks to servers over the network and needs no MuJoCo; starting a server on
this machine does (the ``simx`` distribution installs both). Everything in ``simx_client`` that
starts servers goes through :func:`local_pool`, which imports :mod:`simx_server.pool` only when
called, so ``import simx_client`` never loads the server (``tests/test_layers.py`` checks that no
other client module imports ``simx_server``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from simx_server.pool import ServerPool


def local_pool(count: int, scene: str | None = None, *args: str, **kwargs: Any) -> ServerPool:
    """``count`` started ``simx-server`` processes on this machine, each on a free port.

    Args:
        count: servers to start (>= 1).
        scene: scene file each server loads (MJCF, URDF, ``.ttt``...); None for the default scene.
        *args: more ``simx-server`` command-line arguments, e.g. ``"--speed", "0"``.
        **kwargs: :class:`simx_server.pool.ServerPool`'s keywords (``host``, ``log_dir``...).

    Returns:
        The started :class:`simx_server.pool.ServerPool` (``addresses``, ``claims``, ``close()``).

    Raises:
        simx_server.pool.PoolError: a server did not start (the message has the end of its log).
        ValueError: ``count`` < 1 or an argument the pool refuses.
    """
    from simx_server.pool import ServerPool  # the server side: needs MuJoCo on this machine

    return ServerPool(count, scene, *args, **kwargs)
