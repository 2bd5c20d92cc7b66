"""The simx wire schema, shared by client and server.

Everything that crosses Zenoh is defined here once: key expressions, message shapes, the
msgpack codec, command names and which of their arguments identify them, and the exception
hierarchy both sides use. docs/PROTOCOL.md describes the same schema for other languages.

Key expressions (``prefix`` defaults to ``"simx"``):

* ``<prefix>/call/<client>`` -- the server's queryable (declared on ``<prefix>/call/*``). A client
  queries the key that carries its own id; the payload is a *request* naming the same id (a
  request whose id differs from its key's is refused), the reply's payload is a *response*.
  With the id in the key, Zenoh access control can allow each user only its own ids
  (docs/SECURITY.md). Every request after the ``Hello`` carries, as its Zenoh attachment, the
  proof that the id is its sender's (:mod:`simx_wire.proof`).
* ``<prefix>/stream/<client>`` -- the server publishes a *stream update* for one client after
  every simulation step (and at each idle tick while the simulation is not running).
* ``<prefix>/alive/server`` and ``<prefix>/alive/client/<client>`` -- liveliness tokens.

Messages are msgpack arrays whose first element is the protocol version (arrays, not maps:
a blocking call decodes and encodes four messages, and arrays cost about half as much):

* request  ``[PROTOCOL_VERSION, client, [[name, mode, args], ...]]``
* response ``[PROTOCOL_VERSION, sim_time_ms, server_state, server_time_ms, scene_id, [[ok, value], ...]]``
  where ``value`` is the command's result when ``ok`` is true and an error message otherwise;
* stream update ``[PROTOCOL_VERSION, sim_time_ms, [[name, id_args, ok, value], ...]]``
* refusal, the answer to a request that cannot be read (bad bytes, shape or version): the map
  ``{"v": PROTOCOL_VERSION, "err": message}``. It stays a map in every version, as version 1's
  messages were, so that peers of any two versions understand each other's refusal.

Binary data (images, depth buffers, script buffers) travels as msgpack ``bin``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from typing import Any

import msgpack

from simx_wire import decoded_size

# Re-exported: the command identity's helpers and the quoting of peer values live in modules of their own.
from simx_wire.hashable import IDENTITY_DEPTH as IDENTITY_DEPTH
from simx_wire.hashable import _hashable as _hashable
from simx_wire.text import QUOTE_LIMIT as QUOTE_LIMIT
from simx_wire.text import quote as quote
from simx_wire.text import zenoh_reason as zenoh_reason

PROTOCOL_VERSION = 4  # 3: requests without proof; 2: one call key for every client; 1: maps
DEFAULT_PREFIX = "simx"

# Bits of ``server_state`` (same meaning as V-REP's simx_headeroffset_server_state byte).
STATE_SIM_NOT_STOPPED = 0x01
STATE_SIM_PAUSED = 0x02
STATE_REALTIME = 0x04

# Operation mode bases (high bits of the legacy opmode word).
MODE_ONESHOT = 0x000000
MODE_BLOCKING = 0x010000
MODE_STREAMING = 0x020000
MODE_ONESHOT_SPLIT = 0x030000
MODE_STREAMING_SPLIT = 0x040000
MODE_DISCONTINUE = 0x050000
MODE_BUFFER = 0x060000
MODE_REMOVE = 0x070000
MODE_MASK = 0xFF0000
MODE_ARG_MASK = 0x00FFFF

#: Command name -> how many leading arguments identify the command. Two commands with the
#: same name and identifying arguments are "the same command" for the legacy inbox, the
#: outbox overwrite rule and server-side streams (extApi.c's _getCommandPointer_*).
COMMANDS: dict[str, int] = {
    # connection and simulation
    "Hello": 0, "Bye": 0, "GetPingTime": 0, "StartSimulation": 0, "StopSimulation": 0,
    "PauseSimulation": 0, "Synchronous": 0, "SynchronousTrigger": 0,
    # objects
    "GetObjectHandle": 1, "GetObjects": 1, "GetObjectChild": 2, "GetObjectParent": 1,
    "GetObjectPosition": 2, "GetObjectOrientation": 2, "GetObjectQuaternion": 2,
    "SetObjectPosition": 2, "SetObjectOrientation": 2, "SetObjectQuaternion": 2,
    "SetObjectParent": 1, "GetObjectVelocity": 1, "GetObjectGroupData": 2,
    "GetObjectSelection": 0, "SetObjectSelection": 0, "GetModelProperty": 1, "SetModelProperty": 1,
    "GetObjectFloatParameter": 2, "SetObjectFloatParameter": 2,
    "GetObjectIntParameter": 2, "SetObjectIntParameter": 2,
    # joints
    "GetJointPosition": 1, "SetJointPosition": 1, "SetJointTargetPosition": 1,
    "SetJointTargetVelocity": 1, "SetJointForce": 1, "GetJointForce": 1, "GetJointMaxForce": 1,
    "GetJointMatrix": 1, "SetSphericalJointMatrix": 1,
    # sensors
    "GetVisionSensorImage": 2, "GetVisionSensorDepthBuffer": 1, "SetVisionSensorImage": 1,
    "ReadVisionSensor": 1, "ReadProximitySensor": 1, "ReadForceSensor": 1, "BreakForceSensor": 1,
    # collision and distance
    "GetCollisionHandle": 1, "GetDistanceHandle": 1, "GetCollectionHandle": 1,
    "ReadCollision": 1, "ReadDistance": 1, "CheckCollision": 2, "CheckDistance": 2,
    # scripts, signals, parameters
    "CallScriptFunction": 3,
    "SetIntegerSignal": 1, "GetIntegerSignal": 1, "ClearIntegerSignal": 1,
    "SetFloatSignal": 1, "GetFloatSignal": 1, "ClearFloatSignal": 1,
    "SetStringSignal": 1, "GetStringSignal": 1, "ClearStringSignal": 1,
    "AppendStringSignal": 1, "GetAndClearStringSignal": 1,
    "WriteStringStream": 1, "ReadStringStream": 1,
    "GetIntegerParameter": 1, "SetIntegerParameter": 1, "GetFloatingParameter": 1,
    "SetFloatingParameter": 1, "GetBooleanParameter": 1, "SetBooleanParameter": 1,
    "GetStringParameter": 1, "GetArrayParameter": 1, "SetArrayParameter": 1,
    # scene editing
    "TransferFile": 1, "EraseFile": 1, "LoadModel": 1, "LoadScene": 1, "CloseScene": 0,
    "RemoveObject": 1, "RemoveModel": 1, "CopyPasteObjects": 0, "CreateDummy": 0,
    # messages
    "AddStatusbarMessage": 0, "AuxiliaryConsoleOpen": 0, "AuxiliaryConsoleClose": 1,
    "AuxiliaryConsolePrint": 1, "AuxiliaryConsoleShow": 1, "GetLastErrors": 0,
    # V-REP GUI only (refused by the server)
    "LoadUI": 1, "GetUIHandle": 1, "GetUISlider": 2, "SetUISlider": 2, "GetUIEventButton": 1,
    "GetUIButtonProperty": 2, "SetUIButtonProperty": 2, "SetUIButtonLabel": 2, "RemoveUI": 1,
    "DisplayDialog": 0, "EndDialog": 1, "GetDialogInput": 1, "GetDialogResult": 1,
}

#: Commands that are never overwritten in the outbox nor replaced on the server (legacy
#: "do not overwrite" option bit): each call is executed.
DO_NOT_OVERWRITE = frozenset({
    "CallScriptFunction", "AddStatusbarMessage", "CreateDummy", "AuxiliaryConsolePrint",
    "CopyPasteObjects", "AppendStringSignal", "WriteStringStream",
})

#: Most commands in one request: the server refuses more (simx_server.base.limits), and the
#: client's outbox sends larger batches in several requests.
MAX_COMMANDS_PER_REQUEST = 1024
#: Most bytes of one request: the server's Zenoh session does not even reassemble a larger
#: message (simx_server.base.limits.MAX_ZENOH_MESSAGE_BYTES), so the client refuses to send one.
MAX_REQUEST_BYTES = 64 * 1024 * 1024
#: Most commands waiting in a client's outbox that a blocking ``SynchronousTrigger`` takes along
#: in its request (sent before it, in the same request, as V-REP's client did): such a request
#: is served as the trigger alone would be (in place when the server waits for work).
MAX_CARRIED_COMMANDS = 64
#: The start of the error message of every result of a request the server could not queue
#: (a client's queue or the server's is full): ``[[False, "server busy: <why>"], ...]``, one per
#: command, none executed. A client may send such commands again later (its outbox does).
BUSY = "server busy"


def busy(results: list[Any]) -> bool:
    """Whether a response's results say that the server did not queue the request (:data:`BUSY`)."""
    if not results:
        return False
    for result in results:
        if type(result) is not list or len(result) != 2 or result[0] is not False \
                or type(result[1]) is not str or not result[1].startswith(BUSY):
            return False
    return True


#: Streamed commands whose successive results add up in the client's inbox until read
#: (simxReadStringStream: every step's new data is appended, a read takes it all).
ACCUMULATE = frozenset({"ReadStringStream"})


class SimxError(Exception):
    """Base of every error simx raises inside its packages."""


class ProtocolError(SimxError):
    """A message that does not follow this schema, or a peer of another protocol version."""


class RemoteError(SimxError):
    """A command that the server executed and that failed (legacy return flag 8)."""


class UnknownObjectError(RemoteError):
    """A name or handle that names no object of the loaded scene."""


class ObjectTypeError(RemoteError):
    """A handle of the wrong object type for the command (e.g. a shape given to a joint call)."""


class ArgumentError(RemoteError):
    """An argument of the wrong type, shape or range."""


class ScriptError(RemoteError):
    """A child-script function that is missing or raised."""


class UnsupportedError(RemoteError):
    """A command simx does not implement; answered as a remote error, never with made-up data."""


class LocalError(SimxError):
    """A client-side error, such as an argument that cannot be converted (legacy flag 32)."""


class RefusedError(SimxError):
    """A server listens where the client connects and refused its session (TLS handshake,
    authentication): ``simxStart`` answers -1 at once and logs why."""


def call_key(prefix: str, client: str) -> str:
    """Key expression a client's requests are sent to (the server answers ``<prefix>/call/*``)."""
    return f"{prefix}/call/{client}"


def call_keys(prefix: str = DEFAULT_PREFIX) -> str:
    """Key expression of the server's command queryable: every client's call key."""
    return f"{prefix}/call/*"


def legacy_call_key(prefix: str = DEFAULT_PREFIX) -> str:
    """The call key of protocol versions 1 and 2; the server answers it only with a refusal
    that names the version, so that an old client fails with a clear message."""
    return f"{prefix}/call"


_KEY_SPECIALS = frozenset("/*$?#")


def valid_client_id(client: object) -> bool:
    """Whether ``client`` can be a client id: a non-empty str of at most 128 characters that
    is one key-expression chunk (no ``/ * $ ? #``)."""
    return (type(client) is str and 0 < len(client) <= 128
            and not _KEY_SPECIALS.intersection(client))


def stream_key(prefix: str, client: str) -> str:
    """Key expression on which one client's stream updates are published."""
    return f"{prefix}/stream/{client}"


def server_token_key(prefix: str = DEFAULT_PREFIX) -> str:
    """Liveliness token the server holds while it serves."""
    return f"{prefix}/alive/server"


def client_token_key(prefix: str, client: str) -> str:
    """Liveliness token a client holds while connected."""
    return f"{prefix}/alive/client/{client}"


def peer_key(prefix: str, client: str) -> str:
    """Key of a queryable each client declares before its token: the server queries it once per
    token, and the reply's ``replier_id`` names the Zenoh session that holds the id (the server
    bounds ids per session: limits.MAX_CLIENTS_PER_PEER)."""
    return f"{prefix}/peer/{client}"


def client_token_prefix(prefix: str = DEFAULT_PREFIX) -> str:
    """Key expression matching every client's liveliness token."""
    return f"{prefix}/alive/client/*"


def identity(name: str, args: list[Any]) -> tuple[Any, ...]:
    """The legacy identity of a command: its name and identifying arguments, hashable for any
    msgpack value a client sends (see :func:`_hashable`)."""
    head = args[:COMMANDS.get(name, 0)]
    for a in head:
        if type(a) is list or type(a) is dict:
            return (name, *(_hashable(a) for a in head))
    return (name, *head)


_packers = threading.local()  # a msgpack Packer is reusable but not thread-safe
#: A Packer keeps a buffer as large as the largest message it packed; after a message larger
#: than this many bytes the thread's Packer is replaced, so that the buffer is freed.
PACKER_KEEP_BYTES = 1024 * 1024


def pack(message: Any) -> bytes:
    """msgpack bytes of any message (``bytes`` become ``bin``), with this thread's Packer:
    about half the cost of ``msgpack.packb``, which builds a Packer per call.

    A Zenoh callback run with ``indirect=False`` gets a fresh Python thread state on every
    call, so its Packer is not kept and each call pays ``packb``'s cost; simx packs little
    there (refusals and "busy" answers)."""
    data: bytes
    try:
        data = _packers.packer.pack(message)
    except AttributeError:
        _packers.packer = msgpack.Packer(use_bin_type=True)
        data = _packers.packer.pack(message)
    if len(data) > PACKER_KEEP_BYTES:
        _packers.packer = msgpack.Packer(use_bin_type=True)  # drop the grown buffer
    return data


#: Most values in one request, at any depth (containers, numbers, strings, map keys): twice a
#: script call's values (limits.MAX_SCRIPT_CALL_VALUES). Measured before decoding
#: (:mod:`simx_wire.decoded_size`): one 60 MiB request of 62.9 M empty arrays took a server from
#: 216 MB to 4.7 GB; refused now after walking 2 M of them (about 0.4 s, no memory).
MAX_REQUEST_ITEMS = 1 << 21
#: Most memory one request may take once decoded, in bytes, estimated from its msgpack before
#: decoding (an upper bound; a byte of msgpack can cost up to decoded_size.RATIO = 96 bytes):
#: twice the largest request in bytes, so a simxTransferFile of 64 MiB still fits.
MAX_REQUEST_DECODED_BYTES = 128 * 1024 * 1024
#: Requests up to this many bytes are not measured: their decoded size is at most
#: decoded_size.RATIO times their bytes (96 KiB), which the server counts instead.
MEASURE_ABOVE = 1024


def _unpack(payload: bytes) -> Any:
    try:
        return msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception as exc:  # msgpack raises several unrelated types
        raise ProtocolError(f"undecodable message: {exc}") from exc


def _decode(payload: bytes, size: int, what: str) -> list[Any]:
    """One message of this version: a msgpack array of ``size`` items, the first the version.

    Raises:
        ProtocolError: undecodable, another shape, a peer of another version, or a refusal.
    """
    message = _unpack(payload)
    if type(message) is list and len(message) == size and message[0] == PROTOCOL_VERSION:
        return message
    peer = PROTOCOL_VERSION  # the version the message claims, where it claims one
    if type(message) is dict and "v" in message:
        peer = message["v"]
        if peer == PROTOCOL_VERSION and "err" in message:
            raise ProtocolError(f"the peer refused the message: {str(message['err'])[:1000]}")
    elif type(message) is list and message:
        peer = message[0]
    if peer != PROTOCOL_VERSION:
        raise ProtocolError(
            f"protocol version mismatch: peer speaks {quote(peer)}, this side "
            f"{PROTOCOL_VERSION}; install the same simx version on client and server")
    raise ProtocolError(f"not a simx {what}: expected an array of {size} items, version first")


class RequestEncoder:
    """Encodes one client's requests. The array's fixed part (its size, the version and the
    client id) is packed once; each request appends its command array."""

    __slots__ = ("_head",)

    def __init__(self, client: str):
        self._head = pack([PROTOCOL_VERSION, client, []])[:-1]  # minus the empty array

    def encode(self, commands: list[Any]) -> bytes:
        """The request carrying ``commands`` (``[[name, mode, args], ...]``)."""
        return self._head + pack(commands)

    def encode_packed(self, packed: list[bytes]) -> bytes:
        """The request carrying commands already packed one by one (``pack([name, mode, args])``):
        the same bytes as :meth:`encode` of the unpacked commands, without packing them again."""
        n = len(packed)
        if n < 16:
            size = bytes((0x90 | n,))
        elif n < 0x10000:
            size = b"\xdc" + n.to_bytes(2, "big")
        else:
            size = b"\xdd" + n.to_bytes(4, "big")
        return b"".join((self._head, size, *packed))


def request(client: str, commands: Iterable[list[Any]]) -> bytes:
    """Encode a request carrying ``[name, mode, args]`` commands from ``client``."""
    return RequestEncoder(client).encode(list(commands))


def parse_request(payload: bytes, max_commands: int | None = None) -> tuple[str, list[list[Any]]]:
    """Decode and validate a request; returns ``(client, [[name, mode, args], ...])``
    (:func:`read_request` without the decoded size)."""
    client, cmds, _ = read_request(payload, max_commands)
    return client, cmds


def read_request(payload: bytes, max_commands: int | None = None) -> tuple[str, list[list[Any]], int]:
    """Measure, decode and validate a request: ``(client, [[name, mode, args], ...],
    decoded_bytes)``, where ``decoded_bytes`` bounds the memory the decoded request takes
    (at most MAX_REQUEST_DECODED_BYTES; the server counts it against its queue bounds).

    ``max_commands``: the most commands accepted (the server's limits.MAX_COMMANDS_PER_REQUEST).
    Error messages describe what is wrong by type and position, never by echoing the input.

    The client id is a str here; whether it is a valid id (:func:`valid_client_id`) is the
    server's check, once per new client.

    Raises:
        ProtocolError: more than MAX_REQUEST_ITEMS values or MAX_REQUEST_DECODED_BYTES once
            decoded (measured before anything is decoded), undecodable, another protocol
            version, not the request shape, or too many commands.
    """
    if len(payload) <= MEASURE_ABOVE:
        decoded = decoded_size.RATIO * len(payload)
    else:
        try:
            _, decoded = decoded_size.measure(payload, MAX_REQUEST_ITEMS, MAX_REQUEST_DECODED_BYTES)
        except decoded_size.DecodedSizeError as exc:
            if exc.bound == "items":
                raise ProtocolError(f"request of more than {MAX_REQUEST_ITEMS:,} values refused "
                                    "(protocol.MAX_REQUEST_ITEMS)") from None
            if exc.bound == "bytes":
                raise ProtocolError(f"request refused: it would take more than {MAX_REQUEST_DECODED_BYTES:,} "
                                    "bytes once decoded (protocol.MAX_REQUEST_DECODED_BYTES)") from None
            raise ProtocolError(f"undecodable message: {exc}") from None
    _, client, cmds = _decode(payload, 3, "request")
    if type(client) is not str or type(cmds) is not list:
        raise ProtocolError("request needs a client id (str) and a command list")
    if max_commands is not None and len(cmds) > max_commands:
        raise ProtocolError(f"request of {len(cmds)} commands refused: at most {max_commands} "
                            "(limits.MAX_COMMANDS_PER_REQUEST); send fewer at once")
    for cmd in cmds:
        if type(cmd) is not list or len(cmd) != 3 or type(cmd[0]) is not str \
                or type(cmd[1]) is not int or type(cmd[2]) is not list:
            i = next(i for i, c in enumerate(cmds) if c is cmd)
            raise ProtocolError(f"malformed command {i}: expected [name, mode, args] (str, int, list), "
                                f"got {_shape(cmd)}")
    return client, cmds, decoded


def _shape(value: Any) -> str:
    """A short description of a value's type and size (never its content)."""
    if type(value) is list:
        return f"a list of {len(value)}: [{', '.join(type(v).__name__ for v in value[:4])}{', ...' if len(value) > 4 else ''}]"
    return f"a {type(value).__name__}"


def response(sim_time_ms: int, state: int, results: list[Any], server_time_ms: int = 0, scene_id: int = 0,
             encode: Callable[[Any], bytes] = pack) -> bytes:
    """Encode a response: ``results`` is a list of ``[ok, value_or_message]``; ``encode``: a
    msgpack encoder (the server's for large images)."""
    return encode([PROTOCOL_VERSION, sim_time_ms, state, server_time_ms, scene_id, results])


def unpack_response(payload: bytes) -> list[Any]:
    """Decode a response: ``[version, sim_time_ms, server_state, server_time_ms, scene_id,
    results]``; raises ProtocolError (a refusal included)."""
    message = _decode(payload, 6, "response")
    if type(message[5]) is not list:
        raise ProtocolError("response results are not a list")
    return message


def error_response(message: str) -> bytes:
    """Encode the refusal of a request that could not be read (a map in every version)."""
    return pack({"v": PROTOCOL_VERSION, "err": message})


def stream_update(sim_time_ms: int, entries: list[Any], encode: Callable[[Any], bytes] = pack) -> bytes:
    """Encode a stream update: ``entries`` is a list of ``[name, id_args, ok, value]``;
    ``encode``: a msgpack encoder (the server's for large images)."""
    return encode([PROTOCOL_VERSION, sim_time_ms, entries])


def unpack_stream_update(payload: bytes) -> tuple[int, list[Any]]:
    """Decode a stream update: ``(sim_time_ms, entries)``; raises ProtocolError."""
    _, t, entries = _decode(payload, 3, "stream update")
    if type(entries) is not list:
        raise ProtocolError("stream update entries are not a list")
    return t, entries


# ------------------------------------------------------------------ the viewer feed
# (simx-viewer; docs/PROTOCOL.md "The viewer feed"). An addition to version 3: no message
# above changed, and a server without the feed simply does not answer its query.

def viewer_model_key(prefix: str = DEFAULT_PREFIX) -> str:
    """Key expression of the server's queryable that answers the compiled model (a *viewer model*)."""
    return f"{prefix}/viewer/model"


def viewer_state_key(prefix: str = DEFAULT_PREFIX) -> str:
    """Key expression the server puts a *viewer state* on after every step while a subscriber exists."""
    return f"{prefix}/viewer/state"


def viewer_state(generation: int, time: float, qpos: bytes, qvel: bytes, mocap_pos: bytes,
                 mocap_quat: bytes) -> bytes:
    """Encode a viewer state: ``time`` in s; the arrays as little-endian float64 bytes
    (``ndarray.astype('<f8').tobytes()``) of nq, nv, 3·nmocap and 4·nmocap values."""
    return pack([PROTOCOL_VERSION, generation, time, qpos, qvel, mocap_pos, mocap_quat])


def unpack_viewer_state(payload: bytes) -> list[Any]:
    """Decode a viewer state: ``[version, generation, time_s, qpos, qvel, mocap_pos, mocap_quat]``
    (the arrays as bytes); raises ProtocolError."""
    message = _decode(payload, 7, "viewer state")
    if type(message[1]) is not int or not all(type(b) is bytes for b in message[3:]):
        raise ProtocolError("viewer state: expected [version, generation, time, 4 x bin]")
    return message


def viewer_model(generation: int, mujoco_version: str, mjb: bytes, state: bytes) -> bytes:
    """Encode a viewer model: MuJoCo's binary model (``mj_saveModel``), the MuJoCo version that
    wrote it (an ``mjb`` loads only in the same version), and the current viewer state."""
    return pack([PROTOCOL_VERSION, generation, mujoco_version, mjb, state])


def unpack_viewer_model(payload: bytes) -> list[Any]:
    """Decode a viewer model: ``[version, generation, mujoco_version, mjb, state]``; raises
    ProtocolError (a refusal included)."""
    message = _decode(payload, 5, "viewer model")
    if type(message[1]) is not int or type(message[2]) is not str or type(message[3]) is not bytes \
            or type(message[4]) is not bytes:
        raise ProtocolError("viewer model: expected [version, generation, str, bin, bin]")
    return message
