"""Child scripts: Python (:mod:`~simx_server.scripts.child`) and Lua through lupa
(:mod:`~simx_server.scripts.lua`), their collection and life cycle
(:mod:`~simx_server.scripts.scene_scripts`); the ``sim`` API they call is the table of
:mod:`simx_server.api` (each script's :class:`~simx_server.api.context.CallContext`).

Layer: above :mod:`simx_server.api`; imports ``api``, ``sim`` and ``base`` only. The API reads the
simulation it serves through :class:`~simx_server.sim.state.SimulationView`.
"""
