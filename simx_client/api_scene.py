"""The legacy ``simx*`` functions of scene editing: file transfer, loading models and scenes,
removing, copying and creating objects (re-exported by :mod:`simx_client.api`)."""

from __future__ import annotations

from typing import Any

from simx_wire import constants as C
from simx_client.calls import _command, _connection, log
from simx_client.coercion import _f32, _float, _int, _str


# ------------------------------------------------------------ scene editing
def simxTransferFile(clientID, filePathAndName, fileName_serverSide, timeOut, operationMode):
    """Send a local file to the server's transfer folder: returnCode (32 if it cannot be read)."""
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag
    try:
        with open(_str(filePathAndName), "rb") as f:
            data = f.read()
    except Exception as exc:  # unreadable, or not a path (OSError, LocalError, UnicodeError...)
        log.warning("simxTransferFile: %s: %s", type(exc).__name__, exc)
        return C.simx_return_local_error_flag
    return _command(clientID, "TransferFile", lambda: [_str(fileName_serverSide), data], operationMode)[0]


def simxEraseFile(clientID, fileName_serverSide, operationMode):
    """Delete a transferred file on the server: returnCode."""
    return _command(clientID, "EraseFile", lambda: [_str(fileName_serverSide)], operationMode)[0]


def _client_side(clientID, path: Any, options: Any) -> tuple[int, str]:
    """For options bit 0 (file on the client): transfer it first; returns (rc, server-side name)."""
    import os

    name, opts = _str(path), _int(options)
    if not opts & 1:
        return C.simx_return_ok, name
    remote = os.path.basename(name)
    return simxTransferFile(clientID, name, remote, 5000, C.simx_opmode_blocking), remote


def simxLoadModel(clientID, modelPathAndName, options, operationMode):
    """Load an MJCF model into the running scene: ``(returnCode, baseHandle)``; options bit 0: the
    file is on the client (it is transferred first)."""
    try:
        rc, name = _client_side(clientID, modelPathAndName, options)
    except Exception as exc:
        log.warning("simxLoadModel: bad argument: %s", exc)
        return C.simx_return_local_error_flag, 0
    if rc:
        return rc, 0
    return _command(clientID, "LoadModel", lambda: [name, _int(options)], operationMode, int, 0)


def simxLoadScene(clientID, scenePathAndName, options, operationMode):
    """Replace the scene with an MJCF file (simulation stopped): returnCode."""
    try:
        rc, name = _client_side(clientID, scenePathAndName, options)
    except Exception as exc:
        log.warning("simxLoadScene: bad argument: %s", exc)
        return C.simx_return_local_error_flag
    if rc:
        return rc
    return _command(clientID, "LoadScene", lambda: [name, _int(options)], operationMode)[0]


def simxCloseScene(clientID, operationMode):
    """Replace the scene with an empty one: returnCode."""
    return _command(clientID, "CloseScene", lambda: [], operationMode)[0]


def simxRemoveObject(clientID, objectHandle, operationMode):
    """Remove an object: returnCode."""
    return _command(clientID, "RemoveObject", lambda: [_int(objectHandle)], operationMode)[0]


def simxRemoveModel(clientID, objectHandle, operationMode):
    """Remove a model (the object and everything below it): returnCode."""
    return _command(clientID, "RemoveModel", lambda: [_int(objectHandle)], operationMode)[0]


def simxCopyPasteObjects(clientID, objectHandles, operationMode):
    """Copy objects: ``(returnCode, newObjectHandles)``."""
    return _command(clientID, "CopyPasteObjects", lambda: [[_int(h) for h in objectHandles]],
                    operationMode, list, [])


def simxCreateDummy(clientID, size, color, operationMode):
    """Create a dummy (a site) at the origin: ``(returnCode, dummyHandle)``; color: 12 bytes or None."""
    return _command(clientID, "CreateDummy",
                    lambda: [_f32(_float(size)), None if color is None else [_int(c) for c in color]],
                    operationMode, int, 0)
