"""Calls that never return (script_timeout=0.2 in the scene); fine() answers afterwards."""


def spin(inInts, inFloats, inStrings, inBuffer):
    i = 0
    while True:
        i += 1


def stubborn(inInts, inFloats, inStrings, inBuffer):
    while True:
        try:
            while True:
                pass
        except Exception:  # the interruption is not an Exception: it gets through
            pass


def fine(inInts, inFloats, inStrings, inBuffer):
    return [7]
