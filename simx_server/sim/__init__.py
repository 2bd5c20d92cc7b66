"""The simulated world, and nothing about clients: the MuJoCo model and data with V-REP's object
registry (:mod:`~simx_server.sim.world`, loading MJCF and URDF), joint motors, physics bounds,
poses and rotations, IK groups, kinematics, sensor readings, collisions, object parameters,
vision sensors' rendering, the MjSpec tools, and the run state.

Layer: above :mod:`simx_server.base`; imports only ``base`` (and the wire schema's constants
and protocol errors, :mod:`simx_wire`). Code here takes the simulation it reads as an argument, typed
:class:`~simx_server.sim.state.SimulationView`.
"""
