"""Scripts of a ``.ttt``/``.ttm`` file as files next to the converted MJCF, attached to their
objects with ``simx:OBJECT`` settings (docs/PORTING.md, "Bring your .ttt"):

``child_script=FILE.lua`` (a child script), ``threaded=1`` (an old-style threaded one),
``customization_script=FILE.lua``, ``vrep_version=NNNNN`` (the file's program version, for the
API of its time) and ``script_parameters=FILE.json`` (a JSON list of ``{name, value, unit}``:
V-REP's script simulation parameters, when the script or, from CoppeliaSim 4.3, its object has
any; a value that is not UTF-8 text is ``value_base64``, its bytes unchanged). A CoppeliaSim
4.6+ script object (``SCT``) is a site of the tree (its alias and path resolve,
``sim.getObject('.')`` in it is itself, as coppeliaSimLib's ``simGetObject_internal`` takes the
script object as the emitting object) that carries its own script; with "parent is proxy" set,
the script is its parent's. An object's custom data blocks (``sim.readCustomDataBlock``) go into ``custom_data=FILE.json``
(a JSON object: tag -> the block's bytes in base64), which the scene loader gives to the scripts
(:mod:`simx_server.scene.custom_data`).
"""

from __future__ import annotations

import base64
import json
import re

CHILD, CUSTOMIZATION, MAIN = 1, 6, 0


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "object"


def _unique(stem: str, used: set[str]) -> str:
    """``stem``, with underscores added until no file of this conversion has it (two objects'
    names can be the same once made safe for a file name); recorded in ``used``."""
    while stem in used:
        stem += "_"
    used.add(stem)
    return stem


def write_scripts(conv) -> None:
    """Write each child/customization script of ``conv.scene`` into ``conv.out`` and record its
    settings (a disabled one with ``script_disabled=1``: loaded, not run until enabled); a main
    script that is not V-REP's default is reported."""
    scene = conv.scene
    used: set[str] = set()
    taken = {(s.object, s.type) for s in scene.scripts if scene.objects.get(s.object) is not None
             and scene.objects[s.object].kind != "script"}
    for script in scene.scripts:
        if script.type == MAIN:
            if script.text and not is_default_main_script(script.text):
                conv.report.add("customized main scripts (simx runs its own main loop)")
            continue
        if script.type not in (CHILD, CUSTOMIZATION):
            conv.report.add("retired callback scripts")
            continue
        obj = scene.objects.get(script.object)
        if obj is not None and obj.kind == "script" and script.proxy:
            # 4.6+ "parent is proxy": the script acts for its parent (sim.getObject('.') is the
            # parent), unless that object has a script of this kind already
            parent = scene.objects.get(obj.parent)
            if parent is not None and (parent.handle, script.type) not in taken:
                taken.add((parent.handle, script.type))
                obj = parent
        if obj is None:
            conv.report.add("scripts attached to no object")
            continue
        kind = "child" if script.type == CHILD else "customization"
        ext = "py" if script.language.lower().startswith("py") else "lua"
        stem = _unique(f"{_safe(obj.name)}_{kind}", used)
        file = f"{stem}.{ext}"
        if conv.out is not None:
            (conv.out / file).write_text(script.text.replace("\r\n", "\n"), encoding="utf-8")
        items = [f"{kind}_script={file}"]
        if script.threaded and script.type == CHILD:
            items.append("threaded=1")
        if script.disabled:  # kept, not run: a client may enable it (sim.scriptintparam_enabled)
            items.append("script_disabled=1")
        parameters = script.parameters or obj.script_parameters  # 4.3+ keeps them with the object
        if parameters:
            pfile = f"{stem}_parameters.json"
            if conv.out is not None:
                (conv.out / pfile).write_text(json.dumps([parameter_json(p) for p in parameters], indent=1))
            items.append(f"script_parameters={pfile}")
        if not any(i.startswith("vrep_version=") for i in conv.settings.get(obj.name, [])):
            items.append(f"vrep_version={scene.program_version}")
        conv.setting(obj.name, *items)


#: The code of CoppeliaSim 4.x's default main script (coppeliaSimLib ``DEFAULT_MAINSCRIPT_CODE``:
#: a comment, then ``require('defaultMainScript')``), spelled any way Lua allows.
_DEFAULT_MAIN = re.compile(r"""require\s*\(?\s*(['"])defaultMainScript\1\s*\)?""")


def is_default_main_script(text: str) -> bool:
    """Whether a main script is V-REP's or CoppeliaSim's default one: V-REP 3.x's full text
    (``-- This is the main script``), or 4.x's ``require('defaultMainScript')`` with nothing but
    comments and a ``--lua`` line around it."""
    if "-- This is the main script" in text[:200]:
        return True
    code = "\n".join(line for line in (raw.split("--", 1)[0].strip() for raw in text.splitlines()) if line)
    return _DEFAULT_MAIN.fullmatch(code) is not None


def parameter_json(parameter: dict) -> dict:
    """A script simulation parameter as the JSON file keeps it: ``value`` where the bytes are
    UTF-8 text, else ``value_base64`` (the bytes unchanged: V-REP gives scripts the stored bytes,
    :mod:`simx_server.api.script_parameters`)."""
    value = parameter["value"]
    out = {"name": parameter["name"], "unit": parameter["unit"]}
    if isinstance(value, (bytes, bytearray)):
        try:
            out["value"] = bytes(value).decode("utf-8")
        except UnicodeDecodeError:
            out["value_base64"] = base64.b64encode(value).decode("ascii")
    else:
        out["value"] = value
    return out


def write_custom_data(conv) -> None:
    """Write each object's custom data blocks into ``conv.out`` (``NAME_custom_data.json``) and
    record its ``custom_data=FILE`` setting."""
    used: set[str] = set()
    for obj in conv.scene.objects.values():
        if not obj.custom_data:
            continue
        stem = _unique(f"{_safe(obj.name)}_custom_data", used)
        file = f"{stem}.json"
        if conv.out is not None:
            blocks = {tag: base64.b64encode(data).decode("ascii") for tag, data in obj.custom_data.items()}
            (conv.out / file).write_text(json.dumps(blocks, indent=1))
        conv.setting(obj.name, f"custom_data={file}")
