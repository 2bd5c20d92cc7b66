"""A loaded scene and how it changes: :class:`~simx_server.scene.simulation.Simulation` (world,
vision sensors, child scripts and editor behind start / pause / stop and the synchronous
barrier), the editor (MjSpec edits, scene and model loads: ``editor`` and ``edits``), the
transfer folder and trusted folders (``client_files``), and ``--list-objects`` (``listing``).

Layer: above :mod:`simx_server.scripts`; imports ``scripts``, ``sim`` and ``base`` only.
"""
