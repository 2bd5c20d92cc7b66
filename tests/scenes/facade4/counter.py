# The same step counter in Python: integer signal 'py_steps'.
n = 0


def sysCall_actuation():
    global n
    n += 1
    sim.setInt32Signal("py_steps", n)
