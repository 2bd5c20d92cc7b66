"""V-REP / CoppeliaSim scene (``.ttt``) and model (``.ttm``) files: reader and MJCF converter.

``read(path)`` gives a :class:`~simx_server.scene.ttt.model.TttScene`; ``convert`` writes the
MJCF, meshes, textures and scripts simx loads. Format notes: ``../shared/reference/ttt-format.md``.
"""
