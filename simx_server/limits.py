"""Every bound the server puts on what a client can make it do, in one place.

Clients are untrusted (docs/SECURITY.md): each value that sets work per request, per step or
per scene has a bound here, named in the ``ArgumentError`` (or refusal) a client gets when it
asks for more. The values are chosen so that real legacy programs never meet them; where a
bound has a command-line flag, the flag is named beside it. docs/SECURITY.md lists them all.
"""

from __future__ import annotations

# ----------------------------------------------------------------- simulation step
#: Largest simulation step ``dt`` in s (``--dt``, ``sim_floatparam_simulation_time_step``); dt
#: must also be > 0 and finite. V-REP's default is 0.05 s; 1 s of the UR5 scene is 1,000
#: MuJoCo substeps, about 10 ms of CPU.
MAX_DT = 1.0
#: Most MuJoCo substeps in one simulation step (``dt`` / the model's timestep): the work of one
#: step. Checked when dt changes and when a scene loads (a scene whose ``<option timestep>`` is
#: too small for the dt is refused).
MAX_SUBSTEPS = 10_000

# ----------------------------------------------------------------- vision sensors
#: Largest side of a vision sensor's image in pixels (resolution parameters 1002/1003; the MJCF
#: camera's ``resolution``, checked when a scene loads). A 4096x4096 RGB image is 48 MiB and its
#: depth buffer 64 MiB, both under MAX_REPLY_BYTES.
MAX_RESOLUTION = 4096

# ----------------------------------------------------------------- requests
#: Most commands in one request (a simxPauseCommunication batch of a real program holds tens).
MAX_COMMANDS_PER_REQUEST = 4096
#: Largest request payload in bytes (a simxTransferFile of a mesh or a scene included).
MAX_REQUEST_BYTES = 64 * 1024 * 1024
#: Largest reply a request may produce in bytes (images and buffers included).
MAX_REPLY_BYTES = 128 * 1024 * 1024

# ----------------------------------------------------------------- physics
# Ranges of the values clients (and child scripts) write into MuJoCo's model and data. Each is
# far beyond what a real robot program sets, and small enough that MuJoCo's arithmetic stays
# finite (products of two bounded values stay far below 1e308). Values outside (NaN and
# infinities included) are refused with an ArgumentError naming the bound (docs/SECURITY.md).

#: Largest magnitude of gravity in m/s² (``sim_arrayparam_gravity``): 100 g.
MAX_GRAVITY = 1000.0
#: Smallest and largest mass of a shape in kg (``sim_shapefloatparam_mass``, 3005): 1 mg, 1000 t.
MIN_MASS = 1e-6
MAX_MASS = 1e6
#: Largest principal inertia in kg·m² (inertias scale with a new mass, as in V-REP).
MAX_INERTIA = 1e8
#: Largest coordinate of an object's position in m (``simxSetObjectPosition``: |x|, |y|, |z|).
MAX_POSITION = 1e4
#: Largest joint position or target position (rad or m) a client sets.
MAX_JOINT_POSITION = 1e4
#: Largest target velocity and velocity limit of a joint (rad/s or m/s); torque control through
#: a large target velocity (the usual 1e4 or 9999) stays within it.
MAX_JOINT_VELOCITY = 1e6
#: Largest maximum force/torque of a joint motor (N or N·m, ``simxSetJointForce``).
MAX_JOINT_FORCE = 1e8

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
