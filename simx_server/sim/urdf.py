"""Scenes from URDF files: MuJoCo's URDF compiler with the V-REP conventions of simx.

Every place that reads a scene or model file (:class:`~simx_server.sim.world.World`, the scene
editor, ``simxLoadScene``/``simxLoadModel``) parses it with :func:`load_spec`, as what its content
is (:func:`simx_server.base.file_kinds.kind_of`), whatever its name. An MJCF file is
``mujoco.MjSpec.from_file`` unchanged (under a name MuJoCo's decoders do not take, such as
``x.ttt``: its text, with its folder and its ``<include>``\\ d files). A URDF file (root element
``<robot>``, whatever its name) is compiled by MuJoCo too, then made to map onto V-REP objects as a URDF import into
V-REP would:

* every link stays a body, so every link is a shape named as in the URDF: MuJoCo's URDF
  default ``fusestatic`` (merge links fixed to their parent, the root link into the world) is
  turned off unless the URDF's ``<mujoco><compiler fusestatic=.../></mujoco>`` says otherwise;
* every revolute, continuous and prismatic joint keeps its URDF name and gets a motor in V-REP's
  force/torque mode with its control loop on (``simx:`` ``mode=position``, as V-REP's URDF
  importer enables position control) whose maximum force is the joint's ``<limit effort>``
  (MuJoCo's ``actuatorfrcrange``) and whose upper velocity is its ``<limit velocity>``
  (``max_velocity``; MuJoCo itself ignores it); a ``<mimic>`` joint, which MuJoCo couples to
  its leader with a joint equality, has its motor off (``mode=passive``);
* mesh files are found as MuJoCo finds them (relative to the URDF's folder, or to the
  ``meshdir`` of its ``<mujoco><compiler>``), and ``package://PKG/PATH`` (ROS) names ``PATH``
  in the nearest folder called ``PKG`` among the URDF's folder and its parents (the ROS
  layout ``PKG/urdf/robot.urdf`` + ``PKG/meshes/...``). A mesh that cannot be found is a
  scene error naming the link, the file and where it was looked for.

A URDF cannot express cameras, actuators, sites, lights, sensors or ``simx:`` settings. Add
them in an MJCF scene that attaches the URDF (``<asset><model file="robot.urdf"/></asset>`` and
``<attach model=... body=... prefix=""/>``: MuJoCo parses the URDF itself there, without the
conventions above), or convert it once with ``simx-server robot.urdf --urdf-to-mjcf robot.xml``
(:func:`write_mjcf`: an MJCF with the conventions above written out) and edit that, as V-REP
users import a URDF and save the scene. See docs/SCENES.md, "URDF".

A URDF sent by a client goes through :mod:`simx_server.base.scene_guard` like MJCF: its ``<link>``\\ s
count as bodies, its ``<mesh filename>``\\ s must lie in the transfer folder (``package://``
mapped first), and a ``package://`` URI whose package is not a folder there is refused.
"""

from __future__ import annotations

import logging
import os
import posixpath
import sys
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco

from simx_wire.protocol import RemoteError
from simx_server.base.arguments import quote
from simx_server.base.file_kinds import FileKind, kind_of
from simx_server.base.scene_guard import inside

log = logging.getLogger("simx.world")

# A scene that attaches a URDF keeps its names (prefix=""), as V-REP programs need; MuJoCo warns
# at every compile that such a spec may not save back to XML, which simx never does with it.
warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix", category=UserWarning)

#: URDF joint types that become V-REP joints with a motor.
_MOVING = ("revolute", "continuous", "prismatic")
PACKAGE = "package://"
#: The suffixes MuJoCo's ``MjSpec.from_file`` takes (it picks its decoder by the name, case-sensitive).
_MUJOCO_SUFFIXES = (".xml", ".urdf")
#: ``<include>`` files read for a scene parsed from its text, at most (a file that includes
#: itself ends here too).
_MAX_INCLUDES = 1000


def is_urdf(path: str | Path) -> bool:
    """Whether ``path`` is a URDF file (its root element is ``<robot>``), as MuJoCo decides.
    False for a file that is not well-formed XML (MuJoCo reports that).

    Args:
        path: a file.

    Returns:
        True for a URDF file.
    """
    try:
        for _, el in ET.iterparse(str(path), events=("start",)):
            return el.tag.rsplit("}", 1)[-1] == "robot"
    except (ET.ParseError, OSError, LookupError, ValueError):
        return False
    return False


def load_spec(path: str | Path, root: Path | None = None) -> mujoco.MjSpec:
    """Parse a scene or model file, as what its content is whatever its name: MJCF as MuJoCo
    does, URDF with simx's conventions (module docstring).

    Args:
        path: the MJCF or URDF file (any name: ``scene.ttt`` holding MJCF is MJCF).
        root: for a file sent by a client, its transfer folder: every URDF mesh, ``package://``
            mapped, must lie inside it, checked before anything is looked up (None: not checked;
            :func:`simx_server.base.scene_guard.check_spec` checks MJCF files and the rest).

    Returns:
        The spec, not compiled.

    Raises:
        ValueError: MuJoCo's message, a URDF mesh that cannot be found (naming its link), a file
            that cannot be read, a V-REP / CoppeliaSim file (its MJCF conversion is loaded
            instead: :mod:`simx_server.scene.ttt`), or content that is no scene
            (:class:`~simx_server.base.file_kinds.NotASceneFileError`).
        RemoteError: with ``root``, a URDF mesh outside it (the text never says whether such a
            server file exists).
    """
    path = Path(path)
    try:
        kind = kind_of(path)
    except OSError as exc:
        raise ValueError(f"{path.name}: cannot read it: {exc.strerror or exc}") from None
    if kind is FileKind.VREP:
        raise ValueError(f"{path.name}: a V-REP / CoppeliaSim file: load it through its MJCF conversion")
    spec = mujoco.MjSpec.from_file(str(path)) if path.suffix in _MUJOCO_SUFFIXES else _spec_from_text(path)
    if kind is FileKind.URDF:
        _adapt(spec, path, root)
    return spec


def _spec_from_text(path: Path) -> mujoco.MjSpec:
    """MJCF or URDF under a name MuJoCo's decoders refuse (``could not find decoder``): parsed
    from its text, with the files its ``<include>``\\ s name given by name (each looked up
    relative to the including file's folder, then the main file's, as MuJoCo looks them up) and
    its folder as the model's (meshes, textures and ``meshdir`` relative to it, as from the
    file itself)."""
    folder = path.absolute().parent
    try:
        text = path.read_bytes()
        includes: dict[str, bytes] = {}
        todo = [(text, "")]
        while todo:
            data, here = todo.pop()
            for name in _include_names(data):
                found = [rel for rel in (posixpath.normpath(posixpath.join(here, name)), posixpath.normpath(name))
                         if (folder / rel).is_file()]
                if not found or found[0] in includes:
                    continue  # missing: MuJoCo's parse names it
                if len(includes) >= _MAX_INCLUDES:
                    raise ValueError(f"{path.name}: more than {_MAX_INCLUDES} <include>d files")
                includes[found[0]] = (folder / found[0]).read_bytes()
                todo.append((includes[found[0]], posixpath.dirname(found[0])))
        spec = mujoco.MjSpec.from_string(text.decode("utf-8"), include=includes or None)
    except OSError as exc:
        raise ValueError(f"{path.name}: cannot read it: {exc.strerror or exc}") from None
    spec.modelfiledir = str(folder) + os.sep
    return spec


def _include_names(data: bytes) -> list[str]:
    """The ``file`` of every ``<include>`` of an XML text (none when it is not well-formed:
    MuJoCo's parse then says what is wrong)."""
    try:
        tree = ET.fromstring(data)
    except (ET.ParseError, LookupError, ValueError):
        return []
    return [el.get("file", "") for el in tree.iter()
            if isinstance(el.tag, str) and el.tag.rsplit("}", 1)[-1] == "include" and el.get("file")]


def _adapt(spec: mujoco.MjSpec, path: Path, root: Path | None) -> None:
    robot = ET.parse(path).getroot()
    compiler = robot.find("mujoco/compiler")
    if compiler is None or "fusestatic" not in compiler.attrib:
        spec.compiler.fusestatic = False  # every link a body, named as in the URDF
    settings = {}
    for joint in robot.findall("joint"):
        name = joint.get("name")
        if not name or joint.get("type") not in _MOVING:
            continue
        # a <mimic> joint follows another through MuJoCo's joint equality: V-REP's dependent
        # joint, no motor of its own acting
        data = "mode=passive" if joint.find("mimic") is not None else "mode=position"
        limit = joint.find("limit")
        try:
            velocity = float(limit.get("velocity", "0")) if limit is not None else 0.0
        except ValueError:
            raise ValueError(f"URDF {path.name}: joint {name!r}: <limit velocity={limit.get('velocity')!r}> "
                             "is not a number") from None
        if velocity > 0:
            data += f" max_velocity={velocity!r}"
        settings[name] = data
    for name, data in settings.items():
        spec.add_text(name=f"simx:{name}", data=data)
    # V-REP's URDF import kept adjacent links from colliding; MuJoCo does not filter a body and its
    # parent when the parent is welded to the world (a link touching the base would push against
    # it, and its motor stall at full torque): every joint's two links are excluded from contact.
    # (Not with the author's fusestatic: an exclude would keep a static link from being fused.)
    bodies = {b.name for b in spec.bodies} if not spec.compiler.fusestatic else set()
    for joint in robot.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        pair = (parent.get("link") if parent is not None else None, child.get("link") if child is not None else None)
        if all(name in bodies for name in pair):
            spec.add_exclude(bodyname1=pair[0], bodyname2=pair[1])
    links = {}  # mesh file name -> a link that uses it (for messages)
    for link in robot.findall("link"):
        for mesh in link.iter("mesh"):
            links.setdefault(mesh.get("filename", ""), link.get("name", "?"))
    # Each mesh's path relative to where MuJoCo looks (the URDF's folder joined with meshdir),
    # package:// mapped and strippath applied here, once.
    look_in = _mesh_folder(spec, path)
    for mesh in spec.meshes:
        found = _mesh_file(spec, path, mesh.file, links.get(mesh.file, "?"), root)
        mesh.file = os.path.relpath(found, look_in)
    spec.strippath = False
    _log_self_collisions(spec, path)


def _log_self_collisions(spec: mujoco.MjSpec, path: Path) -> None:
    """One log line naming the links (not adjacent) whose collision shapes touch at the initial
    pose: MuJoCo keeps their contacts, which a URDF's author may not expect."""
    try:
        model = spec.copy().compile()
    except Exception:  # the caller's compile reports it
        return
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pairs = set()
    for c in data.contact[:data.ncon]:
        b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
        if b1 and b2 and b1 != b2:
            pairs.add(tuple(sorted((model.body(b1).name, model.body(b2).name))))
    if pairs:
        log.warning("URDF %s: links in contact at the initial pose, their collisions stay on: %s", path.name,
                    ", ".join(f"{a}-{b}" for a, b in sorted(pairs)[:10]) + (" ..." if len(pairs) > 10 else ""))


def _mesh_folder(spec: mujoco.MjSpec, urdf: Path) -> Path:
    return Path(os.path.normpath(urdf.absolute().parent / (spec.meshdir or "")))


def _mesh_file(spec: mujoco.MjSpec, urdf: Path, name: str, link: str, root: Path | None) -> Path:
    """The mesh file ``name`` of ``link`` (package:// mapped), checked to lie in ``root`` (if
    given), then to exist."""
    where = f"URDF {urdf.name}: link {link!r}: mesh {name!r}"
    folder = urdf.absolute().parent
    if name.startswith(PACKAGE):
        package, _, rest = name[len(PACKAGE):].partition("/")
        base = next((d for d in (folder, *folder.parents) if d.name == package), None)
        if not package or not rest or base is None:
            raise ValueError(f"{where}: no folder named {package!r} holds the URDF (package:// URIs name a "
                             "file in the ROS package's folder, which must be the URDF's folder or one of "
                             "its parents); or write the path relative to the URDF")
        found = Path(os.path.normpath(base / rest))
    else:
        if spec.strippath:
            name = posixpath.basename(name)
        found = Path(os.path.normpath(_mesh_folder(spec, urdf) / name))
    if root is not None and not inside(Path(os.path.realpath(found)), Path(os.path.realpath(root))):
        raise RemoteError(f"URDF {urdf.name} refused: it names the file {quote(name)}; a scene or model sent by "
                          "a client may only use files sent with it (simxTransferFile), inside the transfer folder")
    if not found.is_file():
        raise ValueError(f"{where} not found (looked for {found})")
    return found


def write_mjcf(urdf: str | Path, out: str | Path) -> int:
    """Convert ``urdf`` to an MJCF file ``out`` with simx's conventions written out (links as
    bodies, ``simx:`` texts for the joints' modes and velocities, mesh paths relative to
    ``out``'s folder). Returns the number of bodies. Raises ValueError: ``urdf`` is not a URDF
    or cannot be loaded; OSError: ``out`` cannot be written.

    Args:
        urdf: the URDF file.
        out: the MJCF file to write.

    Returns:
        The number of bodies (the world not counted).

    Raises:
        ValueError: not a URDF file, or MuJoCo cannot load or compile it.
        OSError: ``out`` cannot be written.
    """
    urdf, out = Path(urdf), Path(out)
    if not is_urdf(urdf):
        raise ValueError(f"{urdf}: not a URDF file (its root element is not <robot>)")
    spec = load_spec(urdf)
    model = spec.compile()  # the errors MuJoCo would give the server, before anything is written
    look_in, target = _mesh_folder(spec, urdf), out.absolute().parent
    for mesh in spec.meshes:
        mesh.file = os.path.relpath(os.path.normpath(look_in / mesh.file), target)
    spec.meshdir = ""
    spec.modelfiledir = str(target)  # to_xml compiles again, from where the MJCF will be
    xml = spec.to_xml()
    head, sep, rest = xml.partition("\n")
    note = (f"  <!-- made from {urdf.name} by simx-server --urdf-to-mjcf: links are bodies (shapes), joints have "
            "motors as the simx: texts below say; add cameras, sites, actuators and simx: texts here -->")
    out.write_text(head + sep + note + sep + rest)
    return model.nbody - 1


def main_to_mjcf(urdf: str | None, out: str) -> int:
    """``simx-server robot.urdf --urdf-to-mjcf robot.xml``: 0, or 2 with one line on stderr.

    Args:
        urdf: the URDF file (None or empty: an error).
        out: the MJCF file to write.

    Returns:
        The process exit status: 0 or 2.
    """
    if not urdf:
        print("simx-server: --urdf-to-mjcf: name the URDF file to convert", file=sys.stderr)
        return 2
    try:
        bodies = write_mjcf(urdf, out)
    except (ValueError, OSError) as exc:
        print(f"simx-server: --urdf-to-mjcf: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    print(f"simx-server: wrote {out} ({bodies} bodies) from {urdf}", flush=True)
    return 0
