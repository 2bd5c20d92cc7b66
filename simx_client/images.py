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

:class:`LazyImageList` (opt-in per client with :func:`set_lazy_image_lists`) is the same list
made only when something reads it as a list: ``np.array`` / ``np.asarray`` take the received
bytes directly, so a program that only converts images to arrays (a Gymnasium environment,
a data-set writer) saves the 8-12 ms a 640x480 frame costs to turn into Python ints.
"""

from __future__ import annotations

import array
import sys
from typing import Any, Callable

import numpy as np

__all__ = ["ImageList", "LazyImageList", "set_lazy_image_lists", "lazy_image_lists", "decode_handles"]

_LITTLE = sys.byteorder == "little"  # array's "f" is the machine's float: the wire's float32 on little-endian hosts
_FLOAT32_ARRAY = array.array("f").itemsize == 4
_NUMERIC = frozenset("biufc")  # dtype kinds an array cast gives exactly as NumPy gives from the list
_DEFAULT = {"i": np.dtype(int), "u": np.dtype(int), "b": np.dtype(bool), "f": np.dtype(float)}


class ImageList(list):
    """A legacy image (signed bytes) or depth buffer (floats): a ``list`` with a fast ``__array__``.

    Build it with :meth:`wrap`; ``ImageList(iterable)`` gives one without a kept array (its
    ``__array__`` converts the list itself). Copies (``copy.copy``) keep the type and share
    the kept array (read-only); ``img.copy()``, slices and pickles are plain lists, as they
    would be for a plain list's reader (a pickle loads without simx installed).
    """

    __slots__ = ("_array", "_pending")

    def __init__(self, *args: Any) -> None:
        self._pending = None  # LazyImageList: the function that makes the list from the array
        super().__init__(*args)
        self._array: np.ndarray | None = None

    @classmethod
    def wrap(cls, values: list, array: np.ndarray) -> ImageList:
        """The list ``values`` (a plain list, copied) with ``array`` kept beside it: a 1-D
        array whose elements equal ``values`` (int8 for images, float32 for depth); it is made
        read-only and never changed here.

        Args:
            values: the legacy list.
            array: the same values, 1-D.

        Returns:
            The list.
        """
        self = cls(values)
        array.flags.writeable = False
        self._array = array
        return self

    @classmethod
    def of_floats(cls, data: bytes) -> ImageList:
        """A depth buffer's list of the little-endian float32 values ``data`` holds, made in
        one pass (no intermediate list: :meth:`wrap` of ``values.tolist()`` made the floats,
        then copied the list: 5.4 ms of CPU for 640x480 against 3.9), the float32 array kept
        beside it.

        Args:
            data: n x 4 bytes.

        Returns:
            The list of n floats.
        """
        values = np.frombuffer(data, dtype="<f4")
        if _LITTLE and _FLOAT32_ARRAY:
            self = cls(array.array("f", data))  # a C loop over the values: one float made for each
        else:
            self = cls(values.tolist())
        values.flags.writeable = False
        self._array = values
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
        # A LazyImageList not made yet (_pending set): the kept array is the list's truth.
        if self._pending is None and (kept is None or len(kept) != list.__len__(self)):
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
        if self._pending is not None:
            self._make()  # type: ignore[attr-defined]  # LazyImageList: object/str dtypes read the list
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
        """``list.append``, forgetting the cached array.

        Args:
            value: a pixel value.

        """
        self._array = None
        super().append(value)

    def extend(self, values: Any) -> None:
        """``list.extend``, forgetting the cached array.

        Args:
            values: pixel values.

        """
        self._array = None
        super().extend(values)

    def insert(self, index: Any, value: Any) -> None:
        """``list.insert``, forgetting the cached array.

        Args:
            index: where.
            value: a pixel value.

        """
        self._array = None
        super().insert(index, value)

    def pop(self, *index: Any) -> Any:
        """``list.pop``, forgetting the cached array.

        Args:
            *index: where (none: the last).

        Returns:
            The value removed.

        """
        self._array = None
        return super().pop(*index)

    def remove(self, value: Any) -> None:
        """``list.remove``, forgetting the cached array.

        Args:
            value: the pixel value to remove (the first one).

        """
        self._array = None
        super().remove(value)

    def clear(self) -> None:
        self._array = None
        super().clear()

    def sort(self, *args: Any, **kwargs: Any) -> None:
        """``list.sort``, forgetting the cached array.

        Args:
            *args: ``list.sort``'s.
            **kwargs: ``list.sort``'s (``key``, ``reverse``).

        """
        self._array = None
        super().sort(*args, **kwargs)

    def reverse(self) -> None:
        self._array = None
        super().reverse()


class LazyImageList(ImageList):
    """An :class:`ImageList` whose Python list is made on first use as a list.

    ``np.array(image, dtype=...)`` and ``np.asarray`` convert the received bytes without
    making the list; any other use (``len``, indexing, iteration, comparison, ``repr``,
    ``+``, ``*``, ``in``, pickling, copying aside, every mutation) first makes the list, then the
    object becomes a plain :class:`ImageList` (``type(img)`` changes) and behaves exactly as
    one. C code that reads a list subclass's storage without calling any of its methods sees an
    empty list before that: ``array.array("b", image)`` (a common V-REP idiom before
    ``Image.frombuffer``), ``msgpack.packb(image)``, ``orjson.dumps(image)``; such a program
    must not opt in (or pass ``list(image)``). That is why it is opt-in, per client:
    :func:`set_lazy_image_lists`.
    """

    __slots__ = ()

    @classmethod
    def lazy(cls, array: np.ndarray, to_list: Callable[[np.ndarray], list]) -> LazyImageList:
        """A list of ``to_list(array)``, made when first read as a list (``array``: 1-D int8
        image bytes or float32 depth values, made read-only and never changed here).

        Args:
            array: the values, 1-D.
            to_list: makes the legacy list from ``array``.

        Returns:
            The list, empty until read.
        """
        self = cls()
        array.flags.writeable = False
        self._array = array
        self._pending = to_list
        return self

    def _make(self) -> ImageList:
        to_list = self._pending
        if to_list is not None:
            self._pending = None
            list.extend(self, to_list(self._array))
        self.__class__ = ImageList  # from now on a plain ImageList, at C speed
        return self

    def __copy__(self) -> ImageList:
        if self._pending is None:
            return self._make().__copy__()
        return LazyImageList.lazy(self._array, self._pending)


def _reader(name: str) -> Callable[..., Any]:
    def method(self: LazyImageList, *args: Any, **kwargs: Any) -> Any:
        return getattr(self._make(), name)(*args, **kwargs)

    method.__name__ = name
    method.__doc__ = f"Makes the list, then ``list.{name}``."
    return method


# Every list method but the constructor: reading ones make the list and run ImageList's
# (which drops the kept array where they mutate). __radd__: ``plain + image`` would otherwise
# reach list's C concatenation, which reads the (still empty) storage directly.
for _name in ("__len__", "__getitem__", "__iter__", "__reversed__", "__contains__", "__eq__", "__ne__",
              "__lt__", "__le__", "__gt__", "__ge__", "__repr__", "__add__", "__mul__", "__rmul__",
              "__sizeof__", "__reduce_ex__", "__reduce__", "__deepcopy__", "copy", "index", "count",
              "__setitem__", "__delitem__", "__iadd__", "__imul__", "append", "extend", "insert", "pop",
              "remove", "clear", "sort", "reverse"):
    setattr(LazyImageList, _name, _reader(_name))
LazyImageList.__radd__ = lambda self, other: other + list(self._make())  # type: ignore[attr-defined]
LazyImageList.__hash__ = None  # type: ignore[assignment]

_LAZY_CLIENTS: set[int] = set()


def set_lazy_image_lists(client_id: int, enabled: bool = True) -> None:
    """simx extension (not in vrep.py): ``simxGetVisionSensorImage`` and
    ``simxGetVisionSensorDepthBuffer`` of connection ``client_id`` return
    :class:`LazyImageList` (enabled) or :class:`ImageList` (the default). A program that only
    turns images into arrays saves the list's making (about 8 ms a 640x480 RGB frame, 5 ms a
    depth buffer); the values are the same. Takes effect for replies received afterwards.

    Args:
        client_id: a connection's id (``simxStart``'s return).
        enabled: lazy lists (True) or plain ones (False).
    """
    if enabled:
        _LAZY_CLIENTS.add(int(client_id))
    else:
        _LAZY_CLIENTS.discard(int(client_id))


def lazy_image_lists(client_id: int) -> bool:
    """Whether connection ``client_id`` returns :class:`LazyImageList` images (see
    :func:`set_lazy_image_lists`).

    Args:
        client_id: a connection's id.

    Returns:
        True when enabled.
    """
    return int(client_id) in _LAZY_CLIENTS


def decode_handles(coded: np.ndarray) -> np.ndarray:
    """Handles (int32, ``r + 256 g + 65536 b``, as CoppeliaSim encodes them) of a colour-coded
    (h, w, 3) uint8 image (render mode 2, ``sim_rendermode_colorcoded``); the background is
    white (0xFFFFFF) where no object is.

    Args:
        coded: (h, w, 3) uint8 RGB.

    Returns:
        (h, w) int32 handles; 0xFFFFFF for the background.
    """
    c = coded.astype(np.int32)
    return c[..., 0] | (c[..., 1] << 8) | (c[..., 2] << 16)
