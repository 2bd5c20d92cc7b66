"""Child scripts: Python (:mod:`~simx_server.scripts.child`) and Lua through lupa
(:mod:`~simx_server.scripts.lua`), their collection and life cycle
(:mod:`~simx_server.scripts.scene_scripts`), and the ``sim`` facade they call (``facade_core``
with its objects and sensors parts, ``shapes`` for importShape, ``values`` for argument checks).

Layer: above :mod:`simx_server.sim`; imports ``sim`` and ``base`` only. The facade reads the
simulation it serves through :class:`~simx_server.sim.state.SimulationView`.
"""
