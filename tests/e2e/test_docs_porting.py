"""docs/PORTING.md stays true of the code, and the README's two Kinect pictures come from the code.

Cheap checks, in-process (no server, no network):

* every ```xml block of the guide loads with simx's own loader (``World``: MuJoCo through
  ``MjSpec`` plus the ``simx:`` texts), each ``simx:NAME`` text names an object of it, and
  each named MJCF element is the V-REP object type the guide's mapping table says;
* the guide's complete example scene has exactly the objects its "Its objects:" sentence lists,
  its IK group brings the tip onto the target within the 0.1 mm the guide says, and its
  proximity and force sensors read what the guide says they read;
* every V-REP name of the worked example's table exists in the bundled scene with the V-REP
  type the table gives, and the table covers every name the tutorial's robotControl.py asks for;
* the Kinect's ``fovy`` is the guide's conversion of the Kinect's 57 degrees;
* every ``sim_*``/``simx_*`` constant the guide names exists in simx_client;
* scripts/readme_pictures.py renders the start view (sky: no ball, mostly blue) and the
  tutorial pose (the red ball near the centre), and the committed pictures are small and
  linked from the README.
"""

from __future__ import annotations

import importlib.util
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest

import simx_client
from simx_client import constants as C
from simx_server.sim import proximity, sensors
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import World

try:
    from conftest import ROOT, SCENE
except ImportError:  # tests/ imported as a package
    from tests.conftest import ROOT, SCENE

GUIDE = ROOT / "docs" / "PORTING.md"
README = ROOT / "README.md"
PICTURES = ROOT / "docs" / "images"
TEXT = GUIDE.read_text(encoding="utf-8")

#: V-REP type words of the guide's tables -> sim_object_*_type
TYPES = {
    "shape": C.sim_object_shape_type, "joint": C.sim_object_joint_type, "dummy": C.sim_object_dummy_type,
    "proximity sensor": C.sim_object_proximitysensor_type, "force sensor": C.sim_object_forcesensor_type,
    "vision sensor": C.sim_object_visionsensor_type, "light": C.sim_object_light_type,
}
#: What the tutorial's robotControl.py asks simxGetObjectHandle for (../shared/legacy/README.md).
TUTORIAL_NAMES = {"UR5", *(f"UR5_joint{i}" for i in range(1, 7)), "RG2", "kinect_rgb", "kinect_depth"}


def xml_blocks() -> list[str]:
    return re.findall(r"```xml\n(.*?)```", TEXT, flags=re.S)


def section(title: str) -> str:
    """The guide's text from the heading ``## title...`` to the next ``## ``."""
    match = re.search(rf"^## {re.escape(title)}.*?$(.*?)(?=^## |\Z)", TEXT, flags=re.S | re.M)
    assert match, f"docs/PORTING.md has no section {title!r}"
    return match.group(1)


def load_block(block: str, folder: Path, index: int) -> World:
    text = block if block.lstrip().startswith("<mujoco") else f"<mujoco><worldbody>{block}</worldbody></mujoco>"
    path = folder / f"snippet{index}.xml"
    path.write_text(text)
    return World(path)


def expected_types(root: ET.Element) -> dict[str, int]:
    """V-REP type of each named element, by the guide's mapping (names used once only)."""
    sensor_sites = {s.get("site"): TYPES["proximity sensor"] for s in root.iter("rangefinder")}
    sensor_sites.update({s.get("site"): TYPES["force sensor"] for s in root.iter("force")})
    kinds = {"body": TYPES["shape"], "joint": TYPES["joint"], "camera": TYPES["vision sensor"],
             "light": TYPES["light"]}
    out: dict[str, list[int]] = {}
    for element in root.iter():
        name = element.get("name")
        if not name:
            continue
        if element.tag == "site":
            out.setdefault(name, []).append(sensor_sites.get(name, TYPES["dummy"]))
        elif element.tag in kinds:
            out.setdefault(name, []).append(kinds[element.tag])
    return {name: types[0] for name, types in out.items() if len(types) == 1}


def test_guide_has_xml_snippets():
    assert len(xml_blocks()) >= 1, "docs/PORTING.md lost its MJCF example"


@pytest.mark.parametrize("index", range(len(xml_blocks())))
def test_xml_snippet_loads_as_the_guide_maps_it(index, tmp_path):
    block = xml_blocks()[index]
    world = load_block(block, tmp_path, index)
    root = ET.fromstring(block if block.lstrip().startswith("<mujoco") else f"<w>{block}</w>")
    for text in root.iter("text"):
        name = text.get("name", "")
        if name.startswith("simx:") and not name.startswith("simx:ik:"):
            world.resolve(name[len("simx:"):])  # raises UnknownObjectError for a name that is no object
    types = expected_types(root)
    assert types, "snippet has no named element"
    for name, vrep_type in types.items():
        assert world.resolve(name).type == vrep_type, f"snippet {index}: {name!r} is not the type the guide says"


def test_example_scene_objects_and_ik_as_the_guide_says(tmp_path):
    block = next(b for b in xml_blocks() if "simx:ik:" in b)
    listed = re.search(r"Its objects: (.*?)\. The", TEXT, flags=re.S)
    assert listed, "the guide no longer lists the example's objects"
    claimed: dict[str, int] = {}
    for part in listed.group(1).replace("\n", " ").split(";"):
        words = part.strip()
        kind = next(k for k in TYPES if words.startswith(k) or words.startswith(k.replace("dummy", "dummies")))
        for name in re.findall(r"`([^`]+)`", words):
            claimed[name] = TYPES[kind]
    path = tmp_path / "my_cell.xml"
    path.write_text(block)
    sim = Simulation(path, realtime=False)
    try:
        world = sim.world
        assert {o.name: o.type for o in world.objects.values()} == claimed
        assert "within 0.1 mm" in TEXT
        sim.start()
        for _ in range(100):  # 5 s of simulation: the joints move at up to 1.5 rad/s
            sim.step()
        tip = np.array(world.position(world.resolve("Arm_tip").handle, -1))
        target = np.array(world.position(world.resolve("Arm_target").handle, -1))
        assert np.linalg.norm(tip - target) < 1e-4
        # the sensors' sentence: prox sees Arm_link1 0.66 m away, Wrist_force reads Wrist's weight
        assert "`prox` detects `Arm_link1` 0.66 m away" in TEXT and "reads 2.12 N" in TEXT
        detected, point, seen, _ = proximity.proximity_reading(sim, world.resolve("prox").handle)
        assert detected and seen == world.resolve("Arm_link1").handle
        assert point[2] == pytest.approx(0.66, abs=0.005)
        state, force, _ = sensors.force_sensor_reading(sim, world.resolve("Wrist_force").handle)
        wrist = world.model.body_mass[world.resolve("Wrist").mj_id]
        assert wrist == pytest.approx(0.216, abs=0.001)
        assert np.linalg.norm(force) == pytest.approx(2.12, abs=0.01)
        down = world.data.site_xmat[world.resolve("Wrist_force").mj_id].reshape(3, 3).T @ [0.0, 0.0, -1.0]
        assert np.dot(force, down) == pytest.approx(2.12, abs=0.01)  # along gravity, in the sensor's frame
    finally:
        sim.close()


def test_worked_example_names_exist_in_the_bundled_scene():
    rows = re.findall(r"^\| `([^`]+)` \| ([a-z ]+) \|", section("Worked example"), flags=re.M)
    assert rows, "the worked example's table is gone"
    world = World(SCENE)
    for name, kind in rows:
        assert kind in TYPES, f"unknown V-REP type {kind!r} in the worked example"
        assert world.resolve(name).type == TYPES[kind], f"{name!r} is not a {kind} in {SCENE.name}"
    assert TUTORIAL_NAMES <= {name for name, _ in rows}


def test_kinect_fovy_is_the_guides_conversion():
    cameras = {c.get("name"): float(c.get("fovy")) for c in ET.parse(SCENE).getroot().iter("camera")}
    fovy = math.degrees(2 * math.atan(math.tan(math.radians(57) / 2) * 480 / 640))
    assert f"57 degrees at 640x480: {fovy:.2f}" in TEXT
    assert cameras["kinect_rgb"] == pytest.approx(fovy, abs=0.01)
    assert cameras["kinect_depth"] == pytest.approx(fovy, abs=0.01)


def test_constants_named_in_the_guide_exist():
    # a name followed by ':' is a prefix of MJCF element names (simx_motor:JOINT), not a constant
    names = set(re.findall(r"\b(simx?_[a-z][a-z0-9_]*)\b(?!:)", TEXT)) - {"simx_server", "simx_client"}
    assert names, "no constants found: the pattern is broken"
    missing = sorted(n for n in names if not hasattr(simx_client, n))
    assert not missing, f"docs/PORTING.md names constants simx_client lacks: {missing}"


def test_readme_links_the_guide_and_the_pictures():
    readme = README.read_text(encoding="utf-8")
    assert "docs/PORTING.md" in readme
    for name in ("kinect_start.png", "kinect_tutorial_pose.png"):
        assert f"docs/images/{name}" in readme
        assert (PICTURES / name).stat().st_size < 150_000


def _red(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > 150) & (g < 80) & (b < 80)


def test_readme_pictures_script_renders_sky_then_ball(tmp_path):
    spec = importlib.util.spec_from_file_location("readme_pictures", ROOT / "scripts" / "readme_pictures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    paths = module.write_pictures(tmp_path, width=320)
    assert sorted(p.name for p in paths) == ["kinect_start.png", "kinect_tutorial_pose.png"]
    start = cv2.cvtColor(cv2.imread(str(tmp_path / "kinect_start.png")), cv2.COLOR_BGR2RGB)
    pose = cv2.cvtColor(cv2.imread(str(tmp_path / "kinect_tutorial_pose.png")), cv2.COLOR_BGR2RGB)
    assert start.shape == pose.shape == (240, 320, 3)
    # start: the sky gradient, blue over most of the picture, no ball
    blue = (start[..., 2].astype(int) > start[..., 0].astype(int) + 20)
    assert blue.mean() > 0.8
    assert _red(start).sum() == 0
    # tutorial pose: the red ball near the centre of the picture
    ys, xs = np.nonzero(_red(pose))
    assert len(xs) > 50
    assert abs(xs.mean() - 160) < 60 and abs(ys.mean() - 120) < 60
