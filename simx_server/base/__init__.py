"""The foundation every layer uses: the server's bounds (:mod:`~simx_server.base.limits`), the
checks of a command's arguments (:mod:`~simx_server.base.arguments`) and the guards that read
scene files before MuJoCo does (:mod:`~simx_server.base.scene_guard`).

Layer: the lowest; imports nothing of ``simx_server``.
"""
