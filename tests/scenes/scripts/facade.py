"""A healthy Python child script: echoes its arguments, describes them and counts its inits."""


def sysCall_init():
    sim.setIntegerSignal("py_inits", (sim.getIntegerSignal("py_inits") or 0) + 1)


def echo(inInts, inFloats, inStrings, inBuffer):
    return inInts, inFloats, inStrings, inBuffer


def describe(inInts, inFloats, inStrings, inBuffer):
    return ([len(inInts), len(inFloats), len(inStrings), len(inBuffer)],
            [sim.getSimulationTimeStep()],
            [s.upper() for s in inStrings],
            sim.packFloatTable(inFloats))
