"""``simIK`` over the ZMQ remote API: :class:`simx_server.scripts.sim_ik.SimIK`, the same
implementation child scripts use (docs/COVERAGE.md lists its functions). The ZMQ service makes
one per call over the client's ``sim`` (:class:`~simx_server.zmq.remote_sim.RemoteSim`), on
which the environments live between calls."""

from __future__ import annotations

from simx_server.scripts.sim_ik import SimIK

#: ``simIK`` of a ZMQ client (the service lists ``vars(RemoteSimIK)``'s public functions).
RemoteSimIK = SimIK

__all__ = ["RemoteSimIK"]
