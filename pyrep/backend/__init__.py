"""The calls PyRep's objects make, mapped onto simx's API table (:mod:`pyrep.backend.sim`)."""
