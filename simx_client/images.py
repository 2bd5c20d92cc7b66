"""Legacy image and depth lists that NumPy 2 and fast code can take.

``vrep.py`` returned an image as a flat Python list of signed bytes (-128..127) and a depth
buffer as a list of floats. Legacy programs turn them into arrays with
``np.array(image, dtype=np.uint8)``: NumPy 1 wrapped the negative values (-1 -> 255), NumPy 2
raises ``OverflowError``, and either way converting 921,600 Python ints takes about 30 ms.

:class:`ImageList` is that list, unchanged for every reader (indexing, ``len``, iteration,
equality with a plain list, slicing and ``+`` giving plain lists, ``json``, ``pickle``), that
also keeps the received values as a compact NumPy array beside it and implements
``__array__``: ``np.array(image, dtype=np.uint8)`` wraps signed bytes as NumPy 1 did, and any
numeric dtype is a cast of the kept array (well under a millisecond for 640x480 RGB).
``np.array(image)`` without a dtype gives what it gives for a plain list: int64 for images,
float64 for depth. Any change to the list (``img[i] = v``, ``append``, ``del``, ``+=``,
``sort``, ...) drops the kept array, so the list stays the truth: later conversions read the
list.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["ImageList"]

_NUMERIC = frozenset("biufc")  # dtype kinds an array cast gives exactly as NumPy gives from the list
_DEFAULT = {"i": np.dtype(int), "u": np.dtype(int), "b": np.dtype(bool), "f": np.dtype(float)}


class ImageList(list):
    """A legacy image (signed bytes) or depth buffer (floats): a ``list`` with a fast ``__array__``.

    Build it with :meth:`wrap`; ``ImageList(iterable)`` gives one without a kept array (its
    ``__array__`` converts the list itself). Copies (``copy.copy``) keep the type and share
    the kept array (read-only); ``img.copy()``, slices and pickles are plain lists, as they
    would be for a plain list's reader (a pickle loads without simx installed).
    """

    __slots__ = ("_array",)

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self._array: np.ndarray | None = None

    @classmethod
    def wrap(cls, values: list, array: np.ndarray) -> ImageList:
        """The list ``values`` (a plain list, copied) with ``array`` kept beside it: a 1-D
        array whose elements equal ``values`` (int8 for images, float32 for depth); it is made
        read-only and never changed here."""
        self = cls(values)
        array.flags.writeable = False
        self._array = array
        return self

    # ------------------------------------------------------------------ numpy
    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        """A new array of the list's values: ``dtype`` None gives the plain list's dtype (int64
        for images, float64 for depth); a numeric ``dtype`` casts the kept values as NumPy
        casts arrays (unsigned integers wrap: -1 -> 255 for uint8, as NumPy 1 did for lists);
        other dtypes convert the list itself. ``copy=False`` raises ValueError, as for a list.
        """
        if copy is False:
            raise ValueError("an image list cannot be viewed as an array without a copy")
        kept = self._array
        if kept is None or len(kept) != len(self):
            kept = np.array(list.__getitem__(self, slice(None)))  # the list is the truth
            if kept.dtype.kind not in _NUMERIC:
                return kept if dtype is None else np.array(kept.tolist(), dtype=dtype)
            kept.flags.writeable = False
            self._array = kept
        if dtype is None:
            return kept.astype(_DEFAULT.get(kept.dtype.kind, kept.dtype))
        dtype = np.dtype(dtype)
        if dtype.kind in _NUMERIC and dtype.fields is None and dtype.subdtype is None:
            return kept.astype(dtype)
        return np.array(list.__getitem__(self, slice(None)), dtype=dtype)

    # ------------------------------------------------------------ copies
    def __copy__(self) -> ImageList:
        new = ImageList(self)  # one copy (iterating a list subclass beats slicing it, then copying)
        new._array = self._array
        return new

    def __deepcopy__(self, memo: dict) -> ImageList:
        return self.__copy__()  # the elements are ints or floats: immutable

    def __reduce_ex__(self, protocol: Any) -> tuple:
        return list, (list.__getitem__(self, slice(None)),)

    # ---------------------------------------------- every mutation drops the kept array
    def __setitem__(self, index: Any, value: Any) -> None:
        self._array = None
        super().__setitem__(index, value)

    def __delitem__(self, index: Any) -> None:
        self._array = None
        super().__delitem__(index)

    def __iadd__(self, other: Any) -> ImageList:
        self._array = None
        return super().__iadd__(other)

    def __imul__(self, n: Any) -> ImageList:
        self._array = None
        return super().__imul__(n)

    def append(self, value: Any) -> None:
        self._array = None
        super().append(value)

    def extend(self, values: Any) -> None:
        self._array = None
        super().extend(values)

    def insert(self, index: Any, value: Any) -> None:
        self._array = None
        super().insert(index, value)

    def pop(self, *index: Any) -> Any:
        self._array = None
        return super().pop(*index)

    def remove(self, value: Any) -> None:
        self._array = None
        super().remove(value)

    def clear(self) -> None:
        self._array = None
        super().clear()

    def sort(self, *args: Any, **kwargs: Any) -> None:
        self._array = None
        super().sort(*args, **kwargs)

    def reverse(self) -> None:
        self._array = None
        super().reverse()
