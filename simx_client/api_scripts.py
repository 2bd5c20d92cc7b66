"""The legacy ``simx*`` functions of scripts, signals, parameters, messages and the GUI-only
calls, which are refused (re-exported by :mod:`simx_client.api`)."""

from __future__ import annotations

from typing import Any

from simx_wire import constants as C
from simx_client.calls import _command, log
from simx_client.coercion import _bool, _bytes, _f32, _f32_input, _f32_list, _float, _floats, _int, _str


# ----------------------------------------------------------------- scripts
def simxCallScriptFunction(clientID, scriptDescription, options, functionName, inputInts, inputFloats,
                           inputStrings, inputBuffer, operationMode):
    """Call a child-script function: ``(returnCode, outInts, outFloats, outStrings, outBuffer)``."""

    def args() -> list:
        return [_str(scriptDescription), _int(options), _str(functionName),
                [_int(v) for v in inputInts], _f32_input(inputFloats),
                [_str(v) for v in inputStrings], _bytes(inputBuffer)]

    def shape(value: list) -> tuple:
        ints, floats, strings, buf = value
        return list(ints), _f32_list(floats), list(strings), bytearray(buf)

    rc, value = _command(clientID, "CallScriptFunction", args, operationMode, shape, None)
    return (rc, [], [], [], bytearray()) if value is None else (rc, *value)


# ------------------------------------------------------------------ signals
def _signal_value(value: Any) -> bytes:
    return _bytes(value)


def simxSetIntegerSignal(clientID, signalName, signalValue, operationMode):
    """Set an integer signal (shared by every client and script): returnCode."""
    return _command(clientID, "SetIntegerSignal", lambda: [_str(signalName), _int(signalValue)], operationMode)[0]


def simxGetIntegerSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``; a missing signal is a remote error."""
    return _command(clientID, "GetIntegerSignal", lambda: [_str(signalName)], operationMode, int, 0)


def simxClearIntegerSignal(clientID, signalName, operationMode):
    """Clear an integer signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearIntegerSignal", lambda: [_str(signalName)], operationMode)[0]


def simxSetFloatSignal(clientID, signalName, signalValue, operationMode):
    """Set a float signal: returnCode."""
    return _command(clientID, "SetFloatSignal", lambda: [_str(signalName), _f32(_float(signalValue))],
                    operationMode)[0]


def simxGetFloatSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``."""
    return _command(clientID, "GetFloatSignal", lambda: [_str(signalName)], operationMode, _f32, 0.0)


def simxClearFloatSignal(clientID, signalName, operationMode):
    """Clear a float signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearFloatSignal", lambda: [_str(signalName)], operationMode)[0]


def simxSetStringSignal(clientID, signalName, signalValue, operationMode):
    """Set a string signal (str is UTF-8 encoded; bytes kept as they are): returnCode."""
    return _command(clientID, "SetStringSignal", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxGetStringSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)`` as a bytearray."""
    return _command(clientID, "GetStringSignal", lambda: [_str(signalName)], operationMode, bytearray, bytearray())


def simxGetAndClearStringSignal(clientID, signalName, operationMode):
    """``(returnCode, signalValue)`` as a bytearray; the signal is cleared."""
    return _command(clientID, "GetAndClearStringSignal", lambda: [_str(signalName)], operationMode,
                    bytearray, bytearray())


def simxClearStringSignal(clientID, signalName, operationMode):
    """Clear a string signal ("" clears them all): returnCode."""
    return _command(clientID, "ClearStringSignal", lambda: [_str(signalName)], operationMode)[0]


def simxAppendStringSignal(clientID, signalName, signalValue, operationMode):
    """Append to a string signal (created if missing): returnCode."""
    return _command(clientID, "AppendStringSignal", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxWriteStringStream(clientID, signalName, signalValue, operationMode):
    """Append to a string signal used as a stream: returnCode."""
    return _command(clientID, "WriteStringStream", lambda: [_str(signalName), _signal_value(signalValue)],
                    operationMode)[0]


def simxReadStringStream(clientID, signalName, operationMode):
    """``(returnCode, signalValue)``: what was written to the stream since the last read
    (streaming then buffer; blocking is refused with flag 4, as the legacy client did)."""
    try:
        if _int(operationMode) == C.simx_opmode_blocking:
            return C.simx_return_illegal_opmode_flag, bytearray()
    except Exception:  # _command answers the local error
        pass
    return _command(clientID, "ReadStringStream", lambda: [_str(signalName)], operationMode,
                    bytearray, bytearray())


simxSetInt32Signal = simxSetIntegerSignal
simxGetInt32Signal = simxGetIntegerSignal
simxClearInt32Signal = simxClearIntegerSignal


def simxQuery(clientID, signalName, signalValue, retSignalName, timeOutInMs):
    """Set a string signal, then wait up to ``timeOutInMs`` for another to appear (and clear it):
    ``(returnCode, retSignalValue)``."""
    import time

    try:
        deadline = time.monotonic() + _int(timeOutInMs) / 1000.0
    except Exception as exc:
        log.warning("simxQuery: bad argument: %s", exc)
        return C.simx_return_local_error_flag, bytearray()
    rc = simxSetStringSignal(clientID, signalName, signalValue, C.simx_opmode_blocking)
    if rc:
        return rc, bytearray()
    while True:
        rc, value = simxGetAndClearStringSignal(clientID, retSignalName, C.simx_opmode_blocking)
        if rc == 0:
            return rc, value
        if time.monotonic() >= deadline:
            return rc | C.simx_return_timeout_flag, bytearray()
        time.sleep(0.005)


# --------------------------------------------------------------- parameters
def simxGetIntegerParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_intparam_*."""
    return _command(clientID, "GetIntegerParameter", lambda: [_int(paramIdentifier)], operationMode, int, 0)


def simxSetIntegerParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_intparam_*: returnCode."""
    return _command(clientID, "SetIntegerParameter", lambda: [_int(paramIdentifier), _int(paramValue)],
                    operationMode)[0]


def simxGetFloatingParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_floatparam_* (1: the simulation step in s)."""
    return _command(clientID, "GetFloatingParameter", lambda: [_int(paramIdentifier)], operationMode, _f32, 0.0)


def simxSetFloatingParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_floatparam_*: returnCode."""
    return _command(clientID, "SetFloatingParameter",
                    lambda: [_int(paramIdentifier), _f32(_float(paramValue))], operationMode)[0]


def simxGetBooleanParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_boolparam_*."""
    return _command(clientID, "GetBooleanParameter", lambda: [_int(paramIdentifier)], operationMode, bool, False)


def simxSetBooleanParameter(clientID, paramIdentifier, paramValue, operationMode):
    """Set a sim_boolparam_*: returnCode."""
    return _command(clientID, "SetBooleanParameter", lambda: [_int(paramIdentifier), _bool(paramValue)],
                    operationMode)[0]


def simxGetStringParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValue)`` of a sim_stringparam_*."""
    return _command(clientID, "GetStringParameter", lambda: [_int(paramIdentifier)], operationMode, str, "")


def simxGetArrayParameter(clientID, paramIdentifier, operationMode):
    """``(returnCode, paramValues)``: 3 floats (sim_arrayparam_gravity = 0: m/s²)."""
    return _command(clientID, "GetArrayParameter", lambda: [_int(paramIdentifier)], operationMode,
                    _f32_list, [0.0] * 3)


def simxSetArrayParameter(clientID, paramIdentifier, paramValues, operationMode):
    """Set 3 floats of a sim_arrayparam_*: returnCode."""
    return _command(clientID, "SetArrayParameter", lambda: [_int(paramIdentifier), _floats(paramValues, 3)],
                    operationMode)[0]


simxGetInt32Param = simxGetIntegerParameter
simxSetInt32Param = simxSetIntegerParameter
simxGetFloatParam = simxGetFloatingParameter
simxSetFloatParam = simxSetFloatingParameter
simxGetBoolParam = simxGetBooleanParameter
simxSetBoolParam = simxSetBooleanParameter
simxGetStringParam = simxGetStringParameter
simxGetArrayParam = simxGetArrayParameter
simxSetArrayParam = simxSetArrayParameter


# -------------------------------------------------------- messages and errors
def simxAddStatusbarMessage(clientID, message, operationMode):
    """Write a message to the server's log, prefixed by this client: returnCode."""
    return _command(clientID, "AddStatusbarMessage", lambda: [_str(message)], operationMode)[0]


def simxAuxiliaryConsoleOpen(clientID, title, maxLines, mode, position, size, textColor, backgroundColor,
                             operationMode):
    """Open an auxiliary console (its lines go to the server's log): ``(returnCode, consoleHandle)``."""
    return _command(clientID, "AuxiliaryConsoleOpen", lambda: [_str(title), _int(maxLines), _int(mode)],
                    operationMode, int, 0)


def simxAuxiliaryConsoleClose(clientID, consoleHandle, operationMode):
    """Close an auxiliary console: returnCode."""
    return _command(clientID, "AuxiliaryConsoleClose", lambda: [_int(consoleHandle)], operationMode)[0]


def simxAuxiliaryConsolePrint(clientID, consoleHandle, txt, operationMode):
    """Print to an auxiliary console (None clears it): returnCode."""
    return _command(clientID, "AuxiliaryConsolePrint",
                    lambda: [_int(consoleHandle), None if txt is None else _str(txt)], operationMode)[0]


def simxAuxiliaryConsoleShow(clientID, consoleHandle, showState, operationMode):
    """Show or hide an auxiliary console (headless: only checks the handle): returnCode."""
    return _command(clientID, "AuxiliaryConsoleShow", lambda: [_int(consoleHandle), _bool(showState)],
                    operationMode)[0]


def simxGetLastErrors(clientID, operationMode):
    """``(returnCode, errors)``: this client's remote errors since the last call (then cleared)."""
    return _command(clientID, "GetLastErrors", lambda: [], operationMode, list, [])


# ------------------------------------------- GUI-only calls (honestly refused)
def simxLoadUI(clientID, uiPathAndName, options, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, uiHandles)``."""
    return _command(clientID, "LoadUI", lambda: [_str(uiPathAndName), _int(options)], operationMode, list, [])


def simxGetUIHandle(clientID, uiName, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, handle)``."""
    return _command(clientID, "GetUIHandle", lambda: [_str(uiName)], operationMode, int, 0)


def simxGetUISlider(clientID, uiHandle, uiButtonID, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, position)``."""
    return _command(clientID, "GetUISlider", lambda: [_int(uiHandle), _int(uiButtonID)], operationMode, int, 0)


def simxSetUISlider(clientID, uiHandle, uiButtonID, position, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUISlider", lambda: [_int(uiHandle), _int(uiButtonID), _int(position)],
                    operationMode)[0]


def simxGetUIEventButton(clientID, uiHandle, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, uiEventButtonID, auxValues)``."""
    rc, value = _command(clientID, "GetUIEventButton", lambda: [_int(uiHandle)], operationMode, tuple, None)
    return (rc, 0, [0, 0]) if value is None else (rc, *value)


def simxGetUIButtonProperty(clientID, uiHandle, uiButtonID, operationMode):
    """Custom UIs need V-REP's GUI: remote error. ``(returnCode, prop)``."""
    return _command(clientID, "GetUIButtonProperty", lambda: [_int(uiHandle), _int(uiButtonID)],
                    operationMode, int, 0)


def simxSetUIButtonProperty(clientID, uiHandle, uiButtonID, prop, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUIButtonProperty", lambda: [_int(uiHandle), _int(uiButtonID), _int(prop)],
                    operationMode)[0]


def simxSetUIButtonLabel(clientID, uiHandle, uiButtonID, upStateLabel, downStateLabel, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "SetUIButtonLabel",
                    lambda: [_int(uiHandle), _int(uiButtonID), _str(upStateLabel), _str(downStateLabel)],
                    operationMode)[0]


def simxRemoveUI(clientID, uiHandle, operationMode):
    """Custom UIs need V-REP's GUI: remote error."""
    return _command(clientID, "RemoveUI", lambda: [_int(uiHandle)], operationMode)[0]


def simxDisplayDialog(clientID, titleText, mainText, dialogType, initialText, titleColors, dialogColors,
                      operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, dialogHandle, uiHandle)``."""
    rc, value = _command(clientID, "DisplayDialog",
                         lambda: [_str(titleText), _str(mainText), _int(dialogType), _str(initialText)],
                         operationMode, tuple, None)
    return (rc, 0, 0) if value is None else (rc, *value)


def simxEndDialog(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error."""
    return _command(clientID, "EndDialog", lambda: [_int(dialogHandle)], operationMode)[0]


def simxGetDialogInput(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, inputText)``."""
    return _command(clientID, "GetDialogInput", lambda: [_int(dialogHandle)], operationMode, str, "")


def simxGetDialogResult(clientID, dialogHandle, operationMode):
    """Dialogs need V-REP's GUI: remote error. ``(returnCode, result)``."""
    return _command(clientID, "GetDialogResult", lambda: [_int(dialogHandle)], operationMode, int, 0)
