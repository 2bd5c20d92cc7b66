"""Every bound the server puts on what a client can make it do, in one place.

Clients are untrusted (docs/SECURITY.md): each value that sets work per request, per step or
per scene has a bound here, named in the ``ArgumentError`` (or refusal) a client gets when it
asks for more. The values are chosen so that real legacy programs never meet them; where a
bound has a command-line flag, the flag is named beside it. docs/SECURITY.md lists them all.
"""

from __future__ import annotations

# ----------------------------------------------------------------- simulation step
#: Largest simulation step ``dt`` in s (``--dt``, ``sim_floatparam_simulation_time_step``).
MAX_DT = 1.0
#: Most MuJoCo substeps in one simulation step (``dt`` / the model's timestep).
MAX_SUBSTEPS = 10_000

# ----------------------------------------------------------------- vision sensors
#: Largest side of a vision sensor's image in pixels (resolution parameters 1002/1003).
MAX_RESOLUTION = 4096

# ----------------------------------------------------------------- requests
#: Most commands in one request (a simxPauseCommunication batch of a real program holds tens).
MAX_COMMANDS_PER_REQUEST = 4096
#: Largest request payload in bytes (a simxTransferFile of a mesh or a scene included).
MAX_REQUEST_BYTES = 64 * 1024 * 1024
#: Largest reply a request may produce in bytes (images and buffers included).
MAX_REPLY_BYTES = 128 * 1024 * 1024

# ----------------------------------------------------------------- signals
#: Most signals in the server's store (integer, float and string signals together).
MAX_SIGNALS = 10_000
#: Largest string signal in bytes (``simxSetStringSignal``, ``simxAppendStringSignal``,
#: ``simxWriteStringStream``): room for a packed 1920x1080 RGB image and more.
MAX_SIGNAL_BYTES = 16 * 1024 * 1024
#: Largest size of the whole store in bytes (names and values; a number counts 8 bytes).
MAX_SIGNAL_STORE_BYTES = 64 * 1024 * 1024
#: Longest signal name in characters.
MAX_SIGNAL_NAME = 1024
