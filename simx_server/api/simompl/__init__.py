"""CoppeliaSim's ``simOMPL`` (its OMPL plug-in) on MuJoCo and OMPL's Python bindings, for child
scripts and ZMQ clients (``client.require('simOMPL')``), and the ``pyrep`` package's planner.

Follows CoppeliaRobotics/simOMPL (``sourceCode/plugin.cpp``, ``lua/simOMPL.lua``): a **state
space** (``createStateSpace``) is a joint's position (``simOMPL.StateSpaceType.joint_position``,
``cyclic_joint_position``) or an object's position or pose (``position2d``, ``position3d``,
``pose2d``, ``pose3d``, ``dubins``: a car's, turning no tighter than ``setDubinsParams``'s
radius), :mod:`simx_server.sim.ompl_spaces`; a **task** (``createTask``) gets state spaces, an
algorithm, collision pairs, a start state and goal states, is ``setup``, then ``solve``\\d
(``simplifyPath``, ``interpolatePath``, ``getPath``, or all in one ``compute``). Planning is
OMPL's (:mod:`simx_server.sim.motion_planning`); a state is valid when the task's state
validation callback says so, else when none of its collision pairs collide, tested by MuJoCo on a
scratch copy of the scene's state (the simulation is not moved while planning; simOMPL moves the
scene's joints and objects and restores them). An object whose pose is planned must move freely
(a dynamic shape, a model's base with a free joint): simx places it in the scratch copy.

Not here: weights other than 1 (UnsupportedError). ``setGoal`` (a dummy pair goal),
``setGoalCallback``, ``setProjectionEvaluationCallback``, ``setValidStateSamplerCallback``,
``getPlannerData``, ``projectStates`` and the drawing helpers are not in the table; algorithms
that OMPL's Python bindings lack (:func:`simx_server.sim.motion_planning.available`) raise
UnsupportedError naming themselves.
"""

from __future__ import annotations

from simx_server.api.simompl import planning, tasks  # noqa: F401 (each module registers its functions)
