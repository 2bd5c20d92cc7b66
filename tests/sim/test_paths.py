"""CoppeliaSim 4.3+ object paths (simx_server.sim.paths): aliases without V-REP's #N, paths whose
parts lie anywhere below the previous one, [n], {n}, wildcards, the index option, relative paths."""

from __future__ import annotations

from pathlib import Path

import pytest

from simx_client.protocol import ArgumentError, UnknownObjectError
from simx_server.sim import paths
from simx_server.sim.world import World

SCENES = Path(__file__).resolve().parents[1] / "scenes" / "zmq"


@pytest.fixture(scope="module")
def world():
    return World(SCENES / "messaging" / "movementViaRemoteApi.xml", 0.05)


@pytest.fixture(scope="module")
def pcontroller():
    return World(SCENES / "messaging" / "pControllerViaRemoteApi.xml", 0.05)


def names(world, handles):
    return [world.objects[h].name for h in handles]


def test_alias_is_the_name_without_the_copy_suffix():
    assert paths.alias("joint#12") == "joint" and paths.alias("joint") == "joint"
    assert paths.alias("a#b") == "a#b"  # only a trailing #digits


def test_the_parts_of_a_path_lie_anywhere_below(world):
    blue = paths.find(world, "/blueRobot/joint")
    assert names(world, blue) == ["joint"] + [f"joint#{i}" for i in range(6)]  # chain order
    assert [paths.find_one(world, "/blueRobot/joint", index=i) for i in range(7)] == blue
    assert names(world, paths.find(world, "/redRobot/joint", index=0)) == ["joint#6"]
    assert paths.find(world, "/redRobot/joint", index=7) == []
    assert names(world, paths.find(world, "/greenRobot/target")) == ["target"]
    assert names(world, paths.find(world, "/target")) == ["target"]  # a unique alias: the path may be short
    assert paths.find(world, "/target/greenRobot") == []  # the order of the parts counts


def test_level_scene_and_wildcards(world, pcontroller):
    assert names(pcontroller, paths.find(pcontroller, "/Cuboid[0]/joint")) == ["joint"]
    assert names(pcontroller, paths.find(pcontroller, "/Cuboid[0]")) == ["Cuboid"]  # the top-level one
    assert names(pcontroller, paths.find(pcontroller, "/Cuboid{1}")) == ["Cuboid#0"]  # the second in the scene
    assert paths.find(pcontroller, "/Cuboid[1]") == []  # one Cuboid at the top level
    assert names(world, paths.find(world, "/*Robot")) == ["blueRobot", "redRobot", "greenRobot"]
    assert names(world, paths.find(world, "/blueRobot/blueRobot_link?")) == [f"blueRobot_link{i}" for i in range(1, 8)]


def test_relative_paths_from_a_script_object_or_the_scene_root(world):
    link3 = paths.find_one(world, "/blueRobot_link3")
    assert names(world, paths.find(world, "./joint", proxy=link3)) == ["joint#2", "joint#3", "joint#4", "joint#5"]
    assert names(world, paths.find(world, ":/joint", index=0, proxy=link3)) == ["joint"]  # from the model base
    assert paths.find(world, ".", proxy=link3) == [link3]
    # code with no object (a remote client): ./X, ./X[i] and :/X start from the scene root
    assert paths.find(world, "./blueRobot") == paths.find(world, "/blueRobot") != []
    assert paths.find(world, ":/blueRobot/joint") == paths.find(world, "/blueRobot/joint")
    assert paths.find(world, "./blueRobot[0]") == paths.find(world, "/blueRobot[0]")
    assert paths.find(world, ".") == [] and paths.find(world, ":") == []


def test_legacy_lookup_takes_4x_alias_paths(world):
    # several joints share the alias "joint": only the path tells them apart (simxGetObjectHandle)
    second = world.resolve("/redRobot/joint{1}")
    assert second.handle == paths.find(world, "/redRobot/joint", index=1)[0]
    assert world.resolve("/redRobot/redRobot_link3/joint").handle == paths.find(world, "/redRobot/redRobot_link3/joint")[0]
    assert world.resolve("/redRobot/redRobot_link3/joint").name != world.resolve("/blueRobot/blueRobot_link3/joint").name
    with pytest.raises(UnknownObjectError):
        world.resolve("/redRobot/nothing/joint")
    with pytest.raises(UnknownObjectError):
        world.resolve("/a//b")  # not a path: unknown, as before


def test_legacy_names_and_errors(world):
    assert names(world, paths.find(world, "joint#3")) == ["joint#3"]
    with pytest.raises(UnknownObjectError, match="'/nothing' does not exist"):
        paths.find_one(world, "/nothing")
    for bad in ("/a//b", "/a[x]", "/" + "a/" * 100 + "a", "/" * 2000):
        with pytest.raises(ArgumentError):
            paths.find(world, bad)
