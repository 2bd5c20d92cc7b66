"""A loaded model's tree in V-REP's terms (issue 51, scene/model_tree.py), in process through
the legacy command handlers (what ``simxLoadModel``/``simxRemoveModel``/``simxRemoveObject``
execute): a load returns the model's root, a model base, also when it is a dummy whose shapes
are bodies of the world hung from it by ``vrep_parent=``; a second load's settings name its own
objects; ``RemoveModel`` removes the whole tree, and every removal leaves the scene's meshes,
textures, materials and in-memory files as they were before the load (the scene's own kept).
The operator's own loads are not held to the clients' cost bounds, and an edit MuJoCo cannot
compute changes nothing. Models written by the tests."""

from __future__ import annotations

import pytest

from simx_client.protocol import ArgumentError, ObjectTypeError
from simx_server.base import limits as L
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.commands.objects import OBJECT_HANDLERS as O
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import DUMMY, SHAPE

pytestmark = pytest.mark.renderers_on_demand

CUBE_OBJ = b"v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"

# The scene's own assets: a floor material with its texture, a sky box, and a material nothing uses.
SCENE = b"""<mujoco model="room">
  <asset>
    <texture name="grid" type="2d" builtin="checker" width="32" height="32"/>
    <material name="floor_mat" texture="grid"/>
    <material name="spare_mat" rgba="0 1 0 1"/>
    <texture name="sky" type="skybox" builtin="gradient" width="16" height="16"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" material="floor_mat"/>
    <body name="Table" pos="0 1 0.2"><geom type="box" size="0.2 0.2 0.2"/></body>
  </worldbody>
</mujoco>
"""

# A model rooted at a dummy (a site with model_base=1), as RLBench's task models convert: its
# shapes are bodies of the world hung from it by vrep_parent=; a joint in an unnamed body of the
# world hangs from it too; settings, a collection and a measurement name its objects.
ROOTED = b"""<mujoco model="rooted">
  <asset>
    <mesh name="crate_mesh" file="crate.obj"/>
    <texture name="crate_tex" type="2d" builtin="checker" width="16" height="16"/>
    <material name="crate_mat" texture="crate_tex"/>
  </asset>
  <worldbody>
    <site name="Root" pos="0 0 0.5"/>
    <body name="Crate" pos="0 0 0.5">
      <freejoint/>
      <geom type="mesh" mesh="crate_mesh" material="crate_mat"/>
      <site name="Crate_top" pos="0 0 0.1"/>
    </body>
    <body name="Shelf" pos="1 0 0.2"><geom type="box" size="0.1 0.1 0.1" material="crate_mat"/></body>
    <body pos="-1 0 0.3">
      <joint name="Door_hinge" axis="0 0 1"/>
      <body name="Door"><geom type="box" size="0.1 0.01 0.1"/></body>
    </body>
    <camera name="Root_cam" pos="0 0 2"/>
  </worldbody>
  <custom>
    <text name="simx:Root" data="model_base=1"/>
    <text name="simx:Crate" data="vrep_parent=Root refs=Shelf"/>
    <text name="simx:Shelf" data="vrep_parent=Root"/>
    <text name="simx:Door_hinge" data="vrep_parent=Root"/>
    <text name="simx:Root_cam" data="vrep_parent=Crate"/>
    <text name="simx:collection:crate_parts" data="items=+tree:Crate,+single:Shelf"/>
    <text name="simx.distance:crate_gap" data="entity1=Crate entity2=collection:crate_parts"/>
  </custom>
</mujoco>
"""

# Two top-level bodies that share a mesh; no model base: the first becomes one.
PAIR = b"""<mujoco model="pair">
  <asset><mesh name="m" file="crate.obj"/><material name="pair_mat" rgba="1 0 0 1"/></asset>
  <worldbody>
    <body name="A" pos="0 0 1"><geom type="mesh" mesh="m" material="pair_mat"/></body>
    <body name="B" pos="0.5 0 1"><geom type="mesh" mesh="m"/></body>
  </worldbody>
</mujoco>
"""


def overlapping(n: int) -> bytes:
    """``n`` spheres at one place (every pair in contact as loaded)."""
    bodies = "".join(f'<body name="S{i}" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>'
                     for i in range(n))
    return f'<mujoco model="heap"><worldbody>{bodies}</worldbody></mujoco>'.encode()


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "room.xml").write_bytes(SCENE)
    (tmp_path / "crate.obj").write_bytes(CUBE_OBJ)
    (tmp_path / "rooted.xml").write_bytes(ROOTED)
    (tmp_path / "pair.xml").write_bytes(PAIR)
    return tmp_path


@pytest.fixture
def sim(folder):
    s = Simulation(folder / "room.xml", dt=0.05, realtime=False)
    yield s
    s.close()


def counts(sim) -> dict[str, int]:
    """What a scene holds: MuJoCo's element and asset counts, the in-memory files of the edits'
    spec, the objects."""
    m = sim.world.model
    fields = ("nbody", "njnt", "ngeom", "nsite", "ncam", "nmesh", "nmeshvert", "nmeshface", "ntex", "nmat",
              "ntext", "nu", "nsensor")
    out = {f: int(getattr(m, f)) for f in fields}
    out["files"] = len(sim.editor._live_spec().assets or {})
    out["objects"] = len(sim.world.objects)
    return out


def test_a_model_rooted_at_a_dummy_loads_as_its_root_and_goes_whole(sim, folder):
    w = sim.world
    empty = counts(sim)
    base = H["LoadModel"](sim, [str(folder / "rooted.xml"), 0])
    root = w.get(base)
    assert (root.name, root.type) == ("Root", DUMMY)
    assert O["GetModelProperty"](sim, [base]) == 0  # a model base
    for child in ("Crate", "Shelf", "Door_hinge"):
        assert w.resolve(child).parent == base
    assert w.resolve("Root_cam").parent == w.resolve("Crate").handle
    once = counts(sim)
    assert once["nmesh"] == 1 and once["ntex"] == empty["ntex"] + 1 and once["nmat"] == empty["nmat"] + 1

    # a second load: every name gets #0, and so do the names its settings hold
    again = H["LoadModel"](sim, [str(folder / "rooted.xml"), 0])
    assert w.get(again).name == "Root#0"
    crate = w.resolve("Crate#0")
    assert crate.parent == again and crate.settings["refs"] == "Shelf#0"
    assert w.resolve("Root_cam#0").parent == crate.handle
    assert w.settings["collection:crate_parts#0"]["items"] == "+tree:Crate#0,+single:Shelf#0"
    assert w.settings["collection:crate_parts"]["items"] == "+tree:Crate,+single:Shelf"

    H["RemoveModel"](sim, [again])
    assert counts(sim) == once
    assert not any(n.endswith("#0") for n in w.by_name) and "collection:crate_parts#0" not in w.settings
    H["RemoveModel"](sim, [base])
    assert counts(sim) == empty
    assert not any(k.startswith(("collection:", "crate_gap")) for k in w.settings)
    assert sim.editor._live_spec().material("spare_mat") is not None  # the scene's own, unused: kept
    assert sim.editor._live_spec().texture("sky") is not None
    for _ in range(3):
        sim.step()


def test_removals_keep_assets_that_others_use(sim, folder):
    w = sim.world
    empty = counts(sim)
    base = H["LoadModel"](sim, [str(folder / "pair.xml"), 0])
    assert (w.get(base).name, w.get(base).type) == ("A", SHAPE)
    assert O["GetModelProperty"](sim, [base]) == 0  # an MJCF model's root becomes a model base
    assert w.get(base).settings == {"model_base": "1"}
    H["RemoveObject"](sim, [w.resolve("B").handle])
    assert w.model.nmesh == 1 and len(sim.editor._live_spec().assets) == empty["files"] + 1  # A uses it
    H["RemoveModel"](sim, [base])
    assert counts(sim) == empty


def test_remove_model_wants_a_model_base_or_a_shape(sim, folder):
    base = H["LoadModel"](sim, [str(folder / "rooted.xml"), 0])
    with pytest.raises(ObjectTypeError, match="not a model base"):
        H["RemoveModel"](sim, [sim.world.resolve("Door_hinge").handle])
    with pytest.raises(ArgumentError):
        H["RemoveModel"](sim, [-1])
    H["RemoveModel"](sim, [sim.world.resolve("Crate").handle])  # a shape: its own tree
    assert "Root_cam" not in sim.world.by_name and "Root" in sim.world.by_name
    H["RemoveModel"](sim, [base])


def test_the_operators_loads_are_not_held_to_the_clients_contact_bound(sim, folder, monkeypatch):
    """MAX_SCENE_CONTACTS bounds a client's scene or edit (docs/SECURITY.md); the operator's own
    loads (a server-side file, asked for in process) are not held to it."""
    (folder / "heap.xml").write_bytes(overlapping(6))  # 15 contacts as loaded
    monkeypatch.setattr(L, "MAX_SCENE_CONTACTS", 10)
    with sim.editor.files.acting("a-client"), pytest.raises(ArgumentError, match="MAX_SCENE_CONTACTS"):
        H["LoadModel"](sim, [str(folder / "heap.xml"), 0])
    assert "S0" not in sim.world.by_name
    base = H["LoadModel"](sim, [str(folder / "heap.xml"), 0])
    assert sim.world.get(base).name == "S0"


def test_an_edit_mujoco_cannot_compute_changes_nothing(tmp_path, folder):
    """A model whose contacts as loaded overflow MuJoCo's data arena (here a scene of 64 KiB):
    MuJoCo's fatal error while the edited world is computed becomes an ArgumentError, and the
    world is the one before, still stepping."""
    (tmp_path / "small_arena.xml").write_bytes(SCENE.replace(b"<asset>", b'<size memory="64K"/><asset>', 1))
    (folder / "heap.xml").write_bytes(overlapping(40))
    s = Simulation(tmp_path / "small_arena.xml", dt=0.05, realtime=False)
    try:
        before, handles = counts(s), dict(s.world.by_name)
        with pytest.raises(ArgumentError, match="MuJoCo cannot compute the edited scene's state"):
            H["LoadModel"](s, [str(folder / "heap.xml"), 0])
        assert counts(s) == before and dict(s.world.by_name) == handles
        s.start()
        for _ in range(3):
            s.step()
        assert H["CreateDummy"](s, [0.05, None]) > max(o.handle for o in handles.values())
    finally:
        s.close()
