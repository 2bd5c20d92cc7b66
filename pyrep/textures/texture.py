"""PyRep's ``Texture``: a texture id of the scene."""


class Texture:
    """A texture, by its id (``PyRep.create_texture``, ``Shape.get_texture``)."""

    def __init__(self, texture_id: int):
        self._texture_id = texture_id

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Texture):
            raise NotImplementedError
        return self._texture_id == other._texture_id

    def __hash__(self) -> int:
        return hash(self._texture_id)

    def get_texture_id(self) -> int:
        """The texture's id."""
        return self._texture_id
