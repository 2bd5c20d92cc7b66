"""Child script of PyBox (scripted.xml): functions called with sim.callScriptFunction over ZMQ."""


def echo(*args):
    return args


def describe(table):
    return len(table), sorted(table), sim.getObjectAlias(sim.getObject('.'))


def fail():
    raise ValueError("failing on purpose")
