"""Collections: V-REP's named sets of scene objects, declared by the scene or made at run time.

A scene declares a collection with a custom text (one per collection; ``simx-convert`` writes them
from a ``.ttt`` file's ``GRP`` records)::

    <text name="simx:collection:EverythingButRobot" data="items=+all,-tree:Robot"/>

``items`` lists V-REP's collection elements in order, comma-separated, each ``+`` (additive) or
``-`` (subtractive) and one of V-REP's element types (``sim_collectionelement_*``):

* ``single:NAME`` (loose): the object alone;
* ``tree:NAME`` (from base, included): the object and every object below it;
  ``tree_without_base:NAME`` the same without the object;
* ``chain:NAME`` (from tip, included): the object and its ancestors;
  ``chain_without_tip:NAME`` the same without the object;
* ``all``: every object of the scene.

Elements apply in order: an additive one adds its objects, a subtractive one removes them, as
V-REP resolved a collection. A collection keeps its elements, not their objects: the members are
worked out from the scene's tree as it is when they are asked for, as CoppeliaSim actualizes
every collection whenever the tree changes (``CSceneObjectContainer::actualizeObjectInformation``
after ``setObjectParent``, an added or a removed object; ``CCollection::actualizeCollection``). So
a part re-parented under a robot (PyRep's ``Gripper.grasp``) joins the robot's ``tree``
collection until it is let go, and an element whose object was removed stands for nothing
(CoppeliaSim drops it). Collection handles start at 2,000,000, as V-REP's (declared collections
first, in name order; ``sim.createCollection`` continues from there).
"""

from __future__ import annotations

import logging
import weakref

from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.sim.objects import WORLD, subtree
from simx_server.sim.world import World

log = logging.getLogger("simx.scene")

PREFIX = "collection:"  # simx:collection:NAME
#: V-REP's first collection handle.
FIRST_HANDLE = 2_000_000
#: Most collections of a scene (declared and made at run time together).
MAX_COLLECTIONS = 1000
#: V-REP's element types (``sim_collectionelement_*``, the file's ``Gty``) by their name here.
ELEMENT_TYPES = {"single": 0, "tree": 1, "tree_without_base": 2, "chain": 3, "chain_without_tip": 4, "all": 5}


#: Most elements of one collection (``sim.addItemToCollection`` adds one per call).
MAX_ELEMENTS = 10_000

#: One element: (additive, kind of :data:`ELEMENT_TYPES`, its object's handle or None for ``all``).
Element = tuple[bool, str, "int | None"]


def element_members(world: World, kind: str, handle: int | None) -> list[int]:
    """The objects one element stands for in the scene's tree now (``kind`` as in
    :data:`ELEMENT_TYPES`; ``handle`` its object, None for ``all``): CoppeliaSim's
    ``CCollectionElement::addOrRemoveYourObjects``. An object no longer in the scene stands for
    nothing.

    Args:
        world: the world.
        kind: ``single``, ``tree``, ``tree_without_base``, ``chain``, ``chain_without_tip`` or ``all``.
        handle: the element's object, or None for ``all``.

    Returns:
        Handles (a tree's parents before children, a chain's from its tip).

    Raises:
        ArgumentError: an unknown kind, or no object for a kind that needs one.
    """
    if kind == "all":
        return list(world.objects)
    if kind not in ELEMENT_TYPES:
        raise ArgumentError(f"collection element type {kind!r} is not one of {', '.join(ELEMENT_TYPES)}")
    if handle is None:
        raise ArgumentError(f"collection element {kind!r} needs an object")
    if handle not in world.objects:
        return []
    if kind == "single":
        return [handle]
    if kind in ("tree", "tree_without_base"):
        below = [o.handle for o in subtree(world, handle)]
        return below[1:] if kind == "tree_without_base" else below
    chain, h = [], handle
    while h != WORLD and h in world.objects:
        chain.append(h)
        h = world.objects[h].parent
    return chain[1:] if kind == "chain_without_tip" else chain


def resolve(world: World, elements: list[Element]) -> list[int]:
    """The objects of a collection's elements applied in order (an additive element adds those
    not in yet, a subtractive one removes its own), in the scene's tree now.

    Args:
        world: the world.
        elements: the collection's elements.

    Returns:
        Handles, in the order they were added.
    """
    members: list[int] = []
    seen: set[int] = set()
    for additive, kind, handle in elements:
        chosen = element_members(world, kind, handle)
        if additive:
            for h in chosen:
                if h not in seen:
                    seen.add(h)
                    members.append(h)
        else:
            gone = set(chosen)
            members = [h for h in members if h not in gone]
            seen -= gone
    return members


def parse_elements(world: World, text: str) -> list[Element]:
    """The elements of a declared collection, from its ``items`` setting (see the module).
    Raises ValueError naming the element that is wrong or names no object.

    Args:
        world: the world.
        text: ``+kind:name,-kind:name,...``.

    Returns:
        The elements, in order.
    """
    elements: list[Element] = []
    for item in filter(None, text.split(",")):
        sign, body = item[:1], item[1:]
        if sign not in "+-" or not body:
            raise ValueError(f"element {item!r} does not start with + or -")
        kind, _, name = body.partition(":")
        if kind not in ELEMENT_TYPES:
            raise ValueError(f"element {item!r}: {kind!r} is not one of {', '.join(ELEMENT_TYPES)}")
        handle = None
        if kind != "all":
            obj = world.by_name.get(name)
            if obj is None:
                raise ValueError(f"element {item!r}: no object {name!r} in the scene")
            handle = obj.handle
        elements.append((sign == "+", kind, handle))
    return elements


def parse_items(world: World, text: str) -> list[int]:
    """The members now of a declared collection, from its ``items`` setting (see the module).
    Raises ValueError naming the element that is wrong or names no object.

    Args:
        world: the world.
        text: ``+kind:name,-kind:name,...``.

    Returns:
        Handles, in the order they were added.
    """
    return resolve(world, parse_elements(world, text))


class Collections:
    """The collections of one world: handle -> elements (:data:`Element`), and names.

    Declared collections are read from the world's ``simx:collection:NAME`` settings; a
    declaration with an element that names no object of the scene is logged (one line naming
    the collection and the element) and left out, as a wrong IK group is. Members are worked
    out from the elements in the tree as it is when asked (:meth:`present`)."""

    def __init__(self, world: World):
        self.world = world
        self.model = world.model
        self.elements: dict[int, list[Element]] = {}
        self.names: dict[str, int] = {}
        for key, settings in sorted(world.settings.items()):
            if not key.startswith(PREFIX):
                continue
            name = key[len(PREFIX):]
            try:
                elements = parse_elements(world, settings.get("items", ""))
            except ValueError as exc:
                log.error("collection %r (custom text simx:%s) ignored: %s", name, key, exc)
                continue
            handle = FIRST_HANDLE + len(self.elements)
            self.elements[handle], self.names[name] = elements, handle

    def create(self) -> int:
        """A new empty collection (``sim.createCollection``); its handle.

        Returns:
            The handle.

        Raises:
            ArgumentError: MAX_COLLECTIONS exist already.
        """
        if len(self.elements) >= MAX_COLLECTIONS:
            raise ArgumentError(f"at most {MAX_COLLECTIONS} collections")
        handle = max(self.elements, default=FIRST_HANDLE - 1) + 1
        self.elements[handle] = []
        return handle

    def _elements(self, handle: int) -> list[Element]:
        elements = self.elements.get(handle) if isinstance(handle, int) else None
        if elements is None:
            raise UnknownObjectError(f"no collection with handle {quote(handle)}")
        return elements

    def add(self, handle: int, kind: str, obj: int | None, additive: bool = True) -> None:
        """Add one element to collection ``handle`` (``sim.addItemToCollection``: CoppeliaSim
        keeps the element, and an element the collection has already is not added again).

        Args:
            handle: a collection's handle.
            kind: one of :data:`ELEMENT_TYPES`.
            obj: the element's object (None for ``all``).
            additive: False: the element removes its objects.

        Raises:
            UnknownObjectError: no such collection.
            ArgumentError: an unknown kind, or the collection has MAX_ELEMENTS elements.
        """
        elements = self._elements(handle)
        if kind not in ELEMENT_TYPES:
            raise ArgumentError(f"collection element type {kind!r} is not one of {', '.join(ELEMENT_TYPES)}")
        element = (bool(additive), kind, None if kind == "all" else obj)
        if element in elements:
            return
        if len(elements) >= MAX_ELEMENTS:
            raise ArgumentError(f"collection {handle}: at most {MAX_ELEMENTS} elements")
        elements.append(element)

    def get(self, handle: int) -> list[int]:
        """The members of collection ``handle`` in the scene's tree now. Raises UnknownObjectError.

        Args:
            handle: a collection's handle.

        Returns:
            Object handles.
        """
        return resolve(self.world, self._elements(handle))

    def handle(self, name: str) -> int:
        """The handle of the collection named ``name`` (a trailing ``#`` ignored, as object names).
        Raises UnknownObjectError.

        Args:
            name: the collection's name.

        Returns:
            Its handle.
        """
        key = name[:-1] if isinstance(name, str) and name.endswith("#") else name
        h = self.names.get(key)
        if h is None:
            raise UnknownObjectError(f"collection {quote(name)} does not exist in the scene "
                                     "(declare one with a simx:collection:NAME custom text)")
        return h

    def name(self, handle: int) -> str:
        """The name of collection ``handle`` ("" for one made at run time without a name).

        Args:
            handle: a collection's handle.

        Returns:
            Its name.

        Raises:
            UnknownObjectError: no such collection.
        """
        self._elements(handle)
        return next((n for n, h in self.names.items() if h == handle), "")

    def remove(self, handle: int) -> None:
        """Forget collection ``handle`` (``sim.destroyCollection``).

        Args:
            handle: a collection's handle.

        Raises:
            UnknownObjectError: no such collection.
        """
        self._elements(handle)
        del self.elements[handle]
        self.names = {n: h for n, h in self.names.items() if h != handle}

    def present(self, handle: int) -> list[int]:
        """The members of collection ``handle`` now (its elements in the scene's tree as it is:
        a part grasped under a ``tree`` element's object is one of them).

        Args:
            handle: a collection's handle.

        Returns:
            Object handles.

        Raises:
            UnknownObjectError: no such collection.
        """
        return self.get(handle)


_COLLECTIONS: "weakref.WeakKeyDictionary[World, Collections]" = weakref.WeakKeyDictionary()


def of(world: World) -> Collections:
    """The collections of ``world`` (read from the scene on first use; run-time ones are kept
    across edits, declared ones re-read with the edited model).

    Args:
        world: the world.

    Returns:
        Its :class:`Collections`.
    """
    c = _COLLECTIONS.get(world)
    if c is None:
        c = _COLLECTIONS[world] = Collections(world)
    elif c.model is not world.model:
        fresh = Collections(world)
        for h, elements in c.elements.items():
            if h not in fresh.elements:
                fresh.elements[h] = elements
        c = _COLLECTIONS[world] = fresh
    return c


def is_collection(handle: object) -> bool:
    """Whether ``handle`` is in the collections' number range.

    Args:
        handle: any value.

    Returns:
        True for an int in [FIRST_HANDLE, FIRST_HANDLE + 1,000,000).
    """
    return isinstance(handle, int) and not isinstance(handle, bool) and FIRST_HANDLE <= handle < FIRST_HANDLE + 1_000_000
