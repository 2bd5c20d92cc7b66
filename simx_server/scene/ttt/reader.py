"""Read a ``.ttt``/``.ttm`` file into a :class:`~simx_server.scene.ttt.model.TttScene`.

Serialization 18 (V-REP 3.1.3) to 25 (CoppeliaSim 4.6): records are found by tag, the newer
double-precision twin (``_xx``) preferred over the older float one, unknown records skipped by
their count. Every problem is one :class:`SceneFileError` naming the file and the record.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from simx_server.scene.ttt import custom, filters, kinds, looks, measurements, settings, shapes
from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt.errors import SceneFileError
from simx_server.scene.ttt.geometry import pose7
from simx_server.scene.ttt.model import (Collection, DummyData, ForceSensorData, IkElement, IkGroup, JointData,
                                         ProximityData, Script, ShapeData, Texture, TttObject, TttScene,
                                         VisionData)
from simx_server.scene.ttt.records import Records, light_decode, read_body

OBJECT_KINDS = {
    "SHP": "shape", "JNT": "joint", "DMY": "dummy", "SNR": "proximity_sensor", "RSN": "vision_sensor",
    "FSE": "force_sensor", "CMA": "camera", "LGT": "light", "GRH": "graph", "PAT": "path", "MIL": "mill",
    "MIR": "mirror", "OCT": "octree", "PTC": "point_cloud", "MKR": "marker", "CSO": "other", "SCT": "script",
}


def read(path: str | Path, data: bytes | None = None) -> TttScene:
    """Read a scene or model file.

    Args:
        path: the file (its name is used in errors).
        data: the file's bytes when the caller has them already.

    Raises:
        SceneFileError: unreadable, truncated, corrupted or beyond a bound (docs/SECURITY.md).
        OSError: the file cannot be read.
    """
    file = Path(path).name
    if data is None:
        size = Path(path).stat().st_size
        if size > E.MAX_FILE_BYTES:
            raise SceneFileError(file, "header", f"{size:,} bytes, more than MAX_FILE_BYTES = {E.MAX_FILE_BYTES:,}")
        data = Path(path).read_bytes()
    header, body = read_body(data, file)
    top = Records(body, file)
    scene = TttScene(file=file, serialization=header.serialization, program_version=header.program_version,
                     is_model=header.file_type == 2 or Path(path).suffix.lower() == ".ttm",
                     objects={}, roots=[], scripts=[], collections=[], ik_groups=[], textures={})
    scene.saved_settings = settings.SavedSettings()
    pool = shapes.MeshPool()
    script_bytes = pixels = 0
    for tag, payload in top:
        if tag == "VIN":
            pool.read(top.sub(tag, payload))
    for tag, payload in top:
        try:
            if tag == "VIN":
                continue
            if tag in OBJECT_KINDS or _is_object(payload):
                obj = _read_object(top, tag, payload, pool)
                if obj.kind == "script":  # 4.6+: the script is an object of the tree
                    scene.scripts.append(obj.data)
                    script_bytes += len(obj.data.text)
                    _check_script_bytes(top, tag, script_bytes)
                if obj.handle in scene.objects:
                    raise top.error(tag, f"object handle {obj.handle} used twice")
                scene.objects[obj.handle] = obj
                if obj.developer_data:
                    key = "object custom data of other headers (V-REP's simAddObjectCustomData)"
                    scene.skipped[key] = scene.skipped.get(key, 0) + obj.developer_data
                if len(scene.objects) > E.MAX_OBJECTS:
                    raise top.error(tag, f"more than MAX_OBJECTS = {E.MAX_OBJECTS:,} objects")
            elif tag == "LST":
                scene.scripts.append(_read_script(top.sub(tag, payload)))
                script_bytes += len(scene.scripts[-1].text)
                _check_script_bytes(top, tag, script_bytes)
            elif tag == "GRP":
                scene.collections.append(_read_collection(top.sub(tag, payload)))
            elif tag in ("COL", "DST"):
                m = measurements.read(top.sub(tag, payload), "collision" if tag == "COL" else "distance")
                if m is not None:
                    scene.measurements.append(m)
            elif tag == "IKO":
                scene.ik_groups.append(_read_ik_group(top.sub(tag, payload)))
            elif tag == "DYN":
                _read_dynamics(top.sub(tag, payload), scene)
            elif tag == "SIM":
                _read_simulation(top.sub(tag, payload), scene)
            elif tag == "ENV":
                _read_environment(top.sub(tag, payload), scene)
            elif tag == "TEX":
                tex = _read_texture(top.sub(tag, payload))
                if tex is not None:
                    scene.textures[tex.id] = tex
                    pixels += tex.width * tex.height
                    if pixels > E.MAX_SCENE_TEXTURE_PIXELS:
                        raise top.error(tag, "textures of more than MAX_SCENE_TEXTURE_PIXELS = "
                                        f"{E.MAX_SCENE_TEXTURE_PIXELS:,} pixels in all")
        except SceneFileError:
            raise
        except (struct.error, ValueError, IndexError) as exc:
            raise SceneFileError(file, tag, f"malformed: {exc}") from None
    _build_tree(scene)
    _pick_friction(scene)
    return scene


def _pick_friction(scene: TttScene) -> None:
    """Each shape's friction: its material's Bullet coefficient for the scene's Bullet version
    (``DYN``/``Ver``: 283 is Bullet 2.83, else 2.78, the default of CoppeliaSim 4.1 and of a
    model file, which has no ``DYN``), as ``CDynamicsContainer`` hands it to the engine; the
    other when the material lacks it."""
    pick = 1 if scene.engine == 0 and scene.engine_version == 283 else 0
    for obj in scene.objects.values():
        data = obj.data
        if isinstance(data, ShapeData):
            first, second = data.bullet_friction[pick], data.bullet_friction[1 - pick]
            data.friction = first if first is not None else second


def _check_script_bytes(top: Records, tag: str, total: int) -> None:
    if total > E.MAX_SCRIPT_BYTES:
        raise top.error(tag, f"scripts of more than MAX_SCRIPT_BYTES = {E.MAX_SCRIPT_BYTES:,} bytes in all")


def _is_object(payload: memoryview) -> bool:
    """An object type this reader does not know: its first common record is ``3do`` 57 58 59."""
    return bytes(payload[:10]) == b"3do\x03\x00\x00\x00\x39\x3a\x3b"


def _build_tree(scene: TttScene) -> None:
    """Children lists and roots from each object's parent handle; objects in a parent cycle
    (which V-REP's own tree cannot hold) hang from the world. Linear and iterative: one pass
    over the objects, one walk from the roots (CoppeliaSim keeps its tree by parent pointers,
    ``CSceneObject::getParent``; a cycle is this reader's problem, not V-REP's).

    Raises:
        SceneFileError: the tree is deeper than ``MAX_TREE_DEPTH`` (MuJoCo's XML parser stops
            at 500 nested elements, and a deep chain would make every later walk deep).
    """
    objects = scene.objects
    for obj in objects.values():
        parent = objects.get(obj.parent)
        if parent is None or parent is obj:
            obj.parent = -1
            scene.roots.append(obj)
        else:
            parent.children.append(obj)
    depth: dict[int, int] = {}
    todo = [(obj, 1) for obj in scene.roots]
    while todo:
        obj, d = todo.pop()
        depth[obj.handle] = d
        if d > E.MAX_TREE_DEPTH:
            raise SceneFileError(scene.file, obj.tag, f"object {obj.name!r} lies {d:,} levels deep, "
                                 f"more than MAX_TREE_DEPTH = {E.MAX_TREE_DEPTH}")
        todo.extend((child, d + 1) for child in obj.children)
    cut = [obj for obj in objects.values() if obj.handle not in depth]  # in a parent cycle
    if not cut:
        return
    in_cycle = {obj.handle for obj in cut}
    for obj in cut:
        obj.children = [c for c in obj.children if c.handle not in in_cycle]
    for obj in cut:  # hang each from the world; what hangs from it stays with it
        obj.parent = -1
        scene.roots.append(obj)
    todo = [(obj, 1) for obj in cut]
    while todo:
        obj, d = todo.pop()
        if d > E.MAX_TREE_DEPTH:
            raise SceneFileError(scene.file, obj.tag, f"object {obj.name!r} lies {d:,} levels deep, "
                                 f"more than MAX_TREE_DEPTH = {E.MAX_TREE_DEPTH}")
        todo.extend((child, d + 1) for child in obj.children)


def _read_object(top: Records, tag: str, payload: memoryview, pool) -> TttObject:
    common = Records(payload, top.file, tag, depth=1, counter=top.counter, stop_at_nxt=True)
    typed = Records(payload, top.file, tag, start=common.end, depth=1, counter=top.counter)
    ids = common.ints("Ids", 2)
    if ids is None:
        raise top.error(tag, "scene object without its handle record Ids")
    name = common.string("Nme") or common.string("Anm") or f"{tag}_{int(ids[0])}"
    alias = common.string("Ali") or name.split("#")[0]
    pose = pose7(common.floats("_fq", "Cfq", 7), quat_first=True)
    model_base = bool(common.byte("Va2") & 1) if common.get("Va2") is not None else False
    kind = OBJECT_KINDS.get(tag, "other")
    lar = common.ints("Lar", 1, "<u2")
    obj = TttObject(tag, kind, int(ids[0]), int(ids[1]), name, alias, pose, model_base,
                    layers=int(lar[0]) if lar is not None else 1)
    obj.custom_data, obj.developer_data = custom.read_custom_data(common)
    obj.script_parameters = custom.read_parameters(common, "Lsp")
    obj.references = custom.read_references(common)
    obj.extension = common.string("Rst")  # CSceneObject::serialize: the extension string
    if common.get("Omp") is not None:  # CSceneObject::serialize: _localObjectSpecialProperty
        obj.special = common.int("Omp")
    obj.model_property = common.int("Mpo", 0xF000)
    obj.object_property = common.int("Op2", 0)  # CSceneObject::serialize: _localObjectProperty
    if kind == "shape":
        obj.data = shapes.read_shape(typed, pool)
    elif kind == "joint":
        obj.data = _read_joint(typed)
    elif kind == "dummy":
        size = typed.floats("_y2", "Dy2", 1)
        obj.data = DummyData(float(size[0]) if size is not None else 0.01, typed.int("Lli", -1), typed.int("Dl2", 0))
    elif kind == "proximity_sensor":
        obj.data = _read_proximity(typed)
    elif kind == "vision_sensor":
        obj.data = _read_vision(typed)
    elif kind == "light":
        obj.data = looks.read_light(typed)
    elif kind == "force_sensor":
        size = typed.floats("_iz", "Siz", 1)
        obj.data = ForceSensorData(float(size[0]) if size is not None else 0.01)
    elif kind == "script":
        obj.data = _read_script_object(typed, obj.handle)
    elif kind == "camera":
        obj.data = kinds.read_camera(typed)
    elif kind == "path":
        obj.data = kinds.read_path(typed)
    return obj


def _read_script_object(r: Records, handle: int) -> Script:
    """A CoppeliaSim 4.6+ script object (``SCT``, coppeliaSimLib ``CScript::serialize``): its
    script (``CDetachedScript::serialize``) is the record list in ``Soo``, the one an ``LST``
    holds; it runs as the script of the object itself."""
    script = _read_script(r.sub("Soo"))
    script.handle = script.object = handle
    return script


def _read_joint(r: Records) -> JointData:
    mr = r.floats("_mr", "Pmr", 2)
    minimum, rng = (float(mr[0]), float(mr[1])) if mr is not None else (-np.pi, 2 * np.pi)
    pos = r.floats("_rt", "Prt", 1)
    va9 = r.byte("Va9")
    j = JointData(type=r.int("Jtt", 10), mode=r.int("Jmd", 0), minimum=minimum, range=rng,
                  position=float(pos[0]) if pos is not None else 0.0, cyclic=bool(va9 & 1),
                  motor=bool(va9 & 16), control_loop=bool(va9 & 32),
                  velocity_lock=bool(r.byte("Vaa") & 2))  # CJoint::serialize: _dynamicLockModeWhenInVelocityControl
    mp = r.floats("_mp", "Dmp", 2)
    if mp is not None:
        j.target_velocity, j.max_force = float(mp[0]), float(mp[1])
    tp = r.floats("_tp", "Dtp", 1)
    if tp is not None:
        j.target_position = float(tp[0])
    pid = r.floats(None, "Dpc", 3)
    if pid is not None:
        j.pid = (float(pid[0]), float(pid[1]), float(pid[2]))
    spring = r.floats("_pp", "Spp", 2)
    if spring is not None:
        j.spring = (float(spring[0]), float(spring[1]))
    for tag, fmt in (("_dt", "<idd"), ("Jdt", "<iff")):
        payload = r.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            master, mult, off = struct.unpack_from(fmt, payload, 0)
            if master >= 0:
                j.dependency = (master, mult, off)
            break
    for tag, payload in r:  # in file order, as CJoint::serialize loads them: the last one counts
        if tag in ("_uc", "Ruc") and len(payload) >= (8 if tag == "_uc" else 4):  # 4.4+: _maxVelAccelJerk
            j.max_velocity = float(np.frombuffer(payload[:8], "<f8")[0] if tag == "_uc" else
                                   np.frombuffer(payload[:4], "<f4")[0])
        elif tag == "Ulv" and len(payload) >= 4 and (j.mode == 5 or va9 & 64):  # <= 4.3, dynamic or hybrid
            j.max_velocity = float(np.frombuffer(payload[:4], "<f4")[0])
    size = r.floats("_rg", "Arg", 2)  # CJoint::serialize: _length, _diameter
    if size is not None and all(np.isfinite(size)):
        j.size = (float(size[0]), float(size[1]))
    if r.get("Dcm") is not None:
        j.control_mode = r.int("Dcm")
        j.motor = j.control_mode != 0
        j.control_loop = j.control_mode in (8, 12, 16)
    elif va9 & 128 and j.motor and j.control_loop:
        # <= 4.3: Va9 bit 7, _dynamicMotorPositionControl_torqueModulation, is the spring-damper
        # mode of a motor with its control loop (CJoint::handleDynJointControl: force K e + C de/dt)
        j.control_mode = 12
    return j


def _read_proximity(r: Records) -> ProximityData:
    vol = r.sub("Vod")
    ss3 = vol.floats("_s3", "Ss3", 9) if len(vol.get("_s3") or vol.get("Ss3") or b"") >= 36 else None
    offset, rng, angle = (float(ss3[0]), float(ss3[1]), float(ss3[8])) if ss3 is not None else (0.0, 0.1, 0.0)
    sizes = tuple(float(v) for v in ss3[2:8]) if ss3 is not None else ()
    ssi = vol.ints("Ssi", 1) if len(vol.get("Ssi") or b"") >= 4 else None  # faceNumber, ...
    return ProximityData(type=r.int("Snt", 34), offset=offset, range=rng,
                         angle=angle if np.isfinite(angle) and 0 < angle < 2 * np.pi else 0.0, max_angle=None,
                         sizes=sizes, sensable=r.int("Sst", 16), faces=int(ssi[0]) if ssi is not None else 32)


def _read_vision(r: Records) -> VisionData:
    ccp = r.floats("_cp", "Ccp", 4)
    res = r.ints("Res", 2)
    va3 = r.byte("Va3", 1)
    ortho, angle, near, far = (float(v) for v in ccp) if ccp is not None else (1.0, np.radians(60), 0.01, 10.0)
    w, h = (int(res[0]), int(res[1])) if res is not None else (256, 256)
    va2 = r.byte("Va2")
    return VisionData((w, h), angle, ortho, near, far, perspective=bool(va3 & 1), explicit=bool(va3 & 2),
                      filters=filters.read_filters(r), ignore_rgb=bool(va2 & 2), ignore_depth=bool(va2 & 4),
                      basic_stats=not va2 & 16, background=r.floats(None, "Db2", 3),
                      same_background=bool(va3 & 128), render_mode=r.int("Rmd", 0))


def _read_script(r: Records) -> Script:
    si2 = r.ints("Si2", 3)
    handle, obj, typ = (int(v) for v in si2) if si2 is not None else (-1, -1, 1)
    if obj < 0:
        obj = r.int("Coc", -1)
    va2 = r.byte("Va2")
    raw = r.get("Ste")
    if raw is not None and len(raw) > E.MAX_STRING_BYTES:
        raise r.error("Ste", f"script text of {len(raw):,} bytes, more than MAX_STRING_BYTES = {E.MAX_STRING_BYTES:,}")
    text = light_decode(bytes(raw)).decode("utf-8", "replace").rstrip("\x00") if raw is not None else ""
    lang = r.string("Lne", "lua") if r.get("Lne") is not None else "lua"
    params = custom.read_parameters(r, "Prm")
    return Script(handle, obj, typ, threaded=bool(va2 & 1), disabled=bool(va2 & 2), text=text,
                  language=lang or "lua", parameters=params, proxy=bool(r.byte("Va3") & 4))


def _read_collection(r: Records) -> Collection:
    elements = []
    for tag, payload in r:
        if tag == "Asg":
            handle, kind, additive = None, 0, True
            for t, p in r.sub(tag, payload):
                if t == "Obj" and len(p) >= 4:
                    handle = struct.unpack_from("<i", p, 0)[0]
                elif t == "Gty" and len(p) >= 1:
                    kind = p[0]
                elif t == "Var" and len(p) >= 1:
                    additive = bool(p[0])
            if handle is not None:
                elements.append((handle, kind, additive))
    return Collection(r.string("Grn") or r.string("Nme"), elements, r.int("Gix", -1))


def _pair(r: Records, new: str, *old: str) -> tuple[float, float] | None:
    """Two numbers from ``new`` (doubles) or the first present of ``old`` (floats), or None."""
    v = r.floats(new, None, 2)
    for tag in old:
        if v is None:
            v = r.floats(None, tag, 2)
    return None if v is None else (float(v[0]), float(v[1]))


def _read_ik_group(r: Records) -> IkGroup:
    """An ``IKO`` record (coppeliaSimLib ``CIkGroup_old::serialize``, its elements
    ``CIkElement_old::serialize``): ``Mit`` iterations, ``_pg`` (``Dpg`` float) damping, ``Cmt``
    method; each ``Ike``: ``Ik2`` tip and base, ``Ctr`` constraints, ``_r2`` (``Pr2`` float;
    ``Prc`` float, degrees) angular then linear precision, ``_gt`` (``Wgt`` float) position and
    orientation weights, ``Var`` bit 0 enabled."""
    elements = []
    for tag, payload in r:
        if tag == "Ike":
            sub = r.sub(tag, payload)
            ik2 = sub.ints("Ik2", 2)
            ctr = sub.int("Ctr", 7)
            if ik2 is None:
                continue
            prec = _pair(sub, "_r2", "Pr2")
            if prec is None and (old := sub.floats(None, "Prc", 2)) is not None:  # degrees
                prec = (float(np.radians(old[0])), float(old[1]))
            angular, linear = prec if prec is not None else (np.radians(0.1), 0.0005)
            weights = _pair(sub, "_gt", "Wgt") or (1.0, 1.0)
            enabled = bool(sub.byte("Var", 1) & 1)
            elements.append(IkElement(int(ik2[0]), int(ik2[1]), ctr, (float(linear), float(angular)), weights,
                                      enabled))
    damping = r.floats("_pg", "Dpg", 1)
    settings = dict(iterations=r.int("Mit", 3), damping=0.1 if damping is None else float(damping[0]),
                    method=r.int("Cmt", 0))
    # "Var" (coppeliaSimLib CIkGroup_old::serialize): bit 0 enabled, bit 5 max step sizes honoured,
    # bit 6 explicit handling ("Va2" holds the joint-limit correction). Files before "Var" carried
    # the explicit flag as Va2 bit 1 (kept for those files).
    name = r.string("Nme") or "IK_Group"
    if r.get("Var") is not None:
        var = r.byte("Var")
        return IkGroup(name, elements, explicit=bool(var & 0x40), enabled=bool(var & 1),
                       max_steps=bool(var & 0x20), **settings)
    return IkGroup(name, elements, explicit=bool(r.byte("Va2") & 2), **settings)


def _read_dynamics(r: Records, scene: TttScene) -> None:
    for tag, dtype in (("_n3", "<f8"), ("En3", "<f4"), ("En2", "<f4"), ("Eng", "<f4")):
        payload = r.get(tag)
        if payload is not None and len(payload) >= 4 + 3 * np.dtype(dtype).itemsize:
            scene.engine = struct.unpack_from("<i", payload, 0)[0]
            g = np.frombuffer(payload[4:4 + 3 * np.dtype(dtype).itemsize], dtype=dtype).astype(np.float64)
            if np.all(np.isfinite(g)):
                scene.gravity = g
                scene.saved_settings.gravity_saved = True
            break
    version = r.ints("Ver", 1)  # CDynamicsContainer::serialize: _dynamicEngineVersionToUse
    if version is not None:
        scene.engine_version = int(version[0])
    settings.read_dynamics(r, scene.engine, scene.saved_settings)


def _read_simulation(r: Records, scene: TttScene) -> None:
    """The simulation step and real-time mode (:mod:`simx_server.scene.ttt.settings`)."""
    settings.read_simulation(r, scene.saved_settings)
    if scene.saved_settings.time_step is not None:
        scene.time_step = scene.saved_settings.time_step


def _read_environment(r: Records, scene: TttScene) -> None:
    """The background gradient (``Clc`` up, ``Cld`` down) and the ambient light
    (:func:`~simx_server.scene.ttt.looks.read_ambient`)."""
    up, down = r.floats(None, "Clc", 3), r.floats(None, "Cld", 3)
    if up is not None and down is not None and np.all(np.isfinite(up)) and np.all(np.isfinite(down)):
        scene.background = (np.clip(up, 0, 1), np.clip(down, 0, 1))
    scene.ambient = looks.read_ambient(r, scene.serialization)
    if r.byte("Var") & 16:  # CEnvironment's fogEnabled: V-REP's sensors drew it
        scene.skipped["fog (vision sensors draw none)"] = 1
    fbg = r.floats(None, "Fbg", 3)  # what vision sensors clear to (CVisionSensor: glClearColor)
    if fbg is not None and np.all(np.isfinite(fbg)):
        scene.fog_background = np.clip(fbg, 0, 1)


def _read_texture(r: Records) -> Texture | None:
    ipa = r.ints("Ipa", 3)
    img = r.get("Img")
    if ipa is None or img is None:
        return None
    tid, w, h = (int(v) for v in ipa)
    if w > 0 and h > 0 and w * h > E.MAX_TEXTURE_PIXELS:
        raise r.error("Ipa", f"texture of {w:,} x {h:,} pixels, more than MAX_TEXTURE_PIXELS = {E.MAX_TEXTURE_PIXELS:,}")
    if w <= 0 or h <= 0 or len(img) < w * h * 3:
        return None
    channels = 4 if len(img) >= w * h * 4 else 3
    rgb = np.frombuffer(img[:w * h * channels], np.uint8).reshape(h, w, channels)
    return Texture(tid, r.string("Gon"), w, h, rgb)
