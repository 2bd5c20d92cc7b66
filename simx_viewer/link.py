"""The viewer's connection to a simx-server: the model query and the state subscription.

Keys and messages are the viewer feed's in :mod:`simx_wire.protocol` (docs/PROTOCOL.md,
"The viewer feed"). No window and no drawing here: :class:`ViewerLink` gives MuJoCo models and
states; :mod:`simx_viewer.app` shows them.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import mujoco
import numpy as np
import zenoh

from simx_wire import protocol as P
from simx_client.connection import client_config, config_in_play
from simx_client.refusal import open_session

#: s to wait for the server's answer to a model query.
DEFAULT_TIMEOUT = 10.0
_RETRY = 0.05  # s between model queries that found no server


class NoServerError(RuntimeError):
    """No simx-server answered at the address (or it does not serve the viewer feed)."""


@dataclass(frozen=True)
class ViewerState:
    """One state of the server's simulation.

    Attributes:
        generation: the model's generation this state belongs to.
        time: simulation time, s.
        qpos, qvel: float64 arrays of the model's nq and nv values.
        mocap_pos, mocap_quat: float64 arrays of shape (nmocap, 3) and (nmocap, 4).
    """
    generation: int
    time: float
    qpos: np.ndarray
    qvel: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray

    @classmethod
    def decode(cls, payload: bytes) -> "ViewerState":
        """Read a viewer state message; raises ProtocolError."""
        _, generation, time, qpos, qvel, mpos, mquat = P.unpack_viewer_state(payload)
        f8 = np.dtype("<f8")
        return cls(generation, float(time), np.frombuffer(qpos, f8), np.frombuffer(qvel, f8),
                   np.frombuffer(mpos, f8).reshape(-1, 3), np.frombuffer(mquat, f8).reshape(-1, 4))

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Copy this state into ``data`` and compute the positions (``mj_forward``).

        Raises:
            ValueError: the sizes are not ``model``'s (a state of another generation).
        """
        if (self.qpos.size, self.qvel.size, self.mocap_pos.shape[0]) != (model.nq, model.nv, model.nmocap):
            raise ValueError(f"state of sizes nq={self.qpos.size} nv={self.qvel.size} "
                             f"nmocap={self.mocap_pos.shape[0]} for a model of nq={model.nq} "
                             f"nv={model.nv} nmocap={model.nmocap}")
        data.time = self.time
        data.qpos[:] = self.qpos
        data.qvel[:] = self.qvel
        data.mocap_pos[:] = self.mocap_pos
        data.mocap_quat[:] = self.mocap_quat
        mujoco.mj_forward(model, data)


@dataclass(frozen=True)
class ViewerModel:
    """The server's compiled model with its generation and the state when it was sent."""
    generation: int
    model: mujoco.MjModel
    state: ViewerState


class ViewerLink:
    """A Zenoh client session to one simx-server's viewer feed.

    The state subscription is declared first, so that a viewer that then fetches the model
    misses no change; the newest state waits in one slot (older ones are dropped: a viewer
    shows the present, it does not replay).

    Args:
        host, port: the server's address, as ``simxStart`` takes them (client mode, multicast
            scouting off; the Zenoh config file of ``$SIMX_ZENOH_CONFIG``/``$ZENOH_CONFIG``, if
            any, for TLS and users: ``simx_client.connection.client_config``).
        prefix: the server's key-expression prefix (``simx``).

    Raises:
        NoServerError: Zenoh cannot reach the address.
        LocalError: the Zenoh config file cannot be used.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 19997, prefix: str = P.DEFAULT_PREFIX):
        self.address = f"{host}:{port}"
        self.prefix = prefix
        self._cond = threading.Condition()
        self._latest: bytes | None = None
        self.received = 0
        try:
            self.session = open_session(client_config(host, port), config_in_play())
        except zenoh.ZError as exc:
            reason = P.zenoh_reason(exc).rstrip(" .!")
            raise NoServerError(f"cannot reach a simx-server at {self.address} ({reason})") from None
        self._subscriber = self.session.declare_subscriber(
            P.viewer_state_key(prefix), zenoh.handlers.Callback(self._on_state))

    def _on_state(self, sample: zenoh.Sample) -> None:
        with self._cond:
            self._latest = sample.payload.to_bytes()
            self.received += 1
            self._cond.notify_all()

    def fetch_model(self, timeout: float = DEFAULT_TIMEOUT) -> ViewerModel:
        """Ask the server for its compiled model (``<prefix>/viewer/model``).

        Raises:
            NoServerError: no answer within ``timeout`` s.
            ProtocolError: a refusal (busy), another protocol version, or a malformed answer.
            RuntimeError: the ``mjb`` cannot be loaded (another MuJoCo version: the message
                names both).
        """
        # Right after the session opens, Zenoh may not know the server's queryable yet, and a
        # query then ends at once without a reply: ask again until the deadline.
        # A "server busy" refusal (too many viewers asking at once: limits.MAX_VIEWER_QUERIES,
        # MAX_VIEWER_MODELS_PER_SECOND) is asked again too; at the deadline it is raised.
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            for reply in self.session.get(P.viewer_model_key(self.prefix), timeout=max(left, 0.01)):
                try:
                    return self._read_model(reply)
                except P.ProtocolError as exc:
                    if "server busy" not in str(exc) or time.monotonic() >= deadline:
                        raise
            if time.monotonic() >= deadline:
                break
            time.sleep(_RETRY)
        raise NoServerError(f"no simx-server answered at {self.address} (prefix {self.prefix!r}) "
                            f"within {timeout:g} s")

    @staticmethod
    def _read_model(reply: zenoh.Reply) -> ViewerModel:
        if reply.ok is None:
            raise P.ProtocolError(f"the server answered an error: {reply.err.payload.to_bytes()[:200]!r}")
        _, generation, version, mjb, state = P.unpack_viewer_model(reply.ok.payload.to_bytes())
        try:
            model = mujoco.MjModel.from_binary_path("server.mjb", {"server.mjb": mjb})
        except Exception as exc:
            raise RuntimeError(f"cannot load the server's model ({exc}): the server runs MuJoCo "
                               f"{version}, this viewer {mujoco.mj_versionString()}; install the "
                               "same MuJoCo version on both") from None
        return ViewerModel(generation, model, ViewerState.decode(state))

    def next_state(self, timeout: float) -> ViewerState | None:
        """The newest state received since the last call, waiting up to ``timeout`` s; None if
        none came. Raises ProtocolError for a message that cannot be read."""
        with self._cond:
            if self._latest is None:
                self._cond.wait(timeout)
            payload, self._latest = self._latest, None
        return None if payload is None else ViewerState.decode(payload)

    def close(self) -> None:
        """Close the Zenoh session; idempotent."""
        session, self.session = getattr(self, "session", None), None
        if session is not None:
            try:
                session.close()
            except Exception:
                pass

    def __enter__(self) -> "ViewerLink":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        self.close()
