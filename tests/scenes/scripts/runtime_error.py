"""Run-time errors: a ZeroDivisionError (line 5) and a sim error (line 9); fine() keeps working."""


def fail(inInts, inFloats, inStrings, inBuffer):
    return [1 // 0]


def badObject(inInts, inFloats, inStrings, inBuffer):
    sim.getObjectHandle("no_such_object")


def unknownSim(inInts, inFloats, inStrings, inBuffer):
    sim.noSuchFunction(1)


def fine(inInts, inFloats, inStrings, inBuffer):
    return [42]
