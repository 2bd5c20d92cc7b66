"""A small writer of synthetic V-REP ``.ttt`` files for the reader's tests: records, the
container header, and a Huffman encoder in the Basic Compression Library's format (code tree in
pre-order, MSB first), written independently of the reader."""

from __future__ import annotations

import heapq
import struct

import numpy as np


def rec(tag: str, payload: bytes) -> bytes:
    return tag.encode() + struct.pack("<i", len(payload)) + payload


def lst(*records: bytes) -> bytes:
    """A record list (ends with EOO)."""
    return b"".join(records) + b"EOO"


def string(text: str | bytes) -> bytes:
    """An i32-length-prefixed string (text as UTF-8, bytes unchanged)."""
    raw = text if isinstance(text, bytes) else text.encode()
    return struct.pack("<i", len(raw)) + raw


def f32(*values) -> bytes:
    return struct.pack(f"<{len(values)}f", *values)


def i32(*values) -> bytes:
    return struct.pack(f"<{len(values)}i", *values)


def common(handle: int, parent: int, name: str, pos=(0, 0, 0), quat=(1, 0, 0, 0), extra: bytes = b"") -> bytes:
    """A scene object's common part, up to NXT (Cfq: qw qx qy qz x y z); ``extra``: more common
    records (:func:`alias`, :func:`model_base`, :func:`custom_data_3x`, ...)."""
    return (rec("3do", bytes([57, 58, 59])) + rec("Cfq", f32(*quat, *pos)) + rec("Ids", i32(handle, parent))
            + rec("Nme", string(name)) + extra + b"NXT")


def alias(text: str) -> bytes:
    """CoppeliaSim 4.3's alias record."""
    return rec("Ali", string(text))


def model_base() -> bytes:
    return rec("Va2", bytes([1]))


def custom_data_3x(blocks: dict[str, bytes], other_headers: int = 0) -> bytes:
    """V-REP 3.x custom data (``Cod`` -> ``Dat``): simWriteCustomDataBlock's block (header
    356248756) of (entry size, tag size, tag + NUL, data) entries, and ``other_headers`` blocks
    of other developer headers."""
    entries = b""
    for tag, data in blocks.items():
        t = tag.encode() + b"\0"
        entries += i32(8 + len(t) + len(data), len(t)) + t + data
    dat = i32(356248756, len(entries)) + entries
    for k in range(other_headers):
        dat += i32(12345 + k, 8) + i32(1, 2)
    return rec("Cod", lst(rec("Dat", dat)))


def custom_data_4x(blocks: dict[str, bytes]) -> bytes:
    """CoppeliaSim 4.3+ custom data (``Cda``: one ``Cdt`` per tag: tag, data, each i32-sized)."""
    return rec("Cda", lst(*(rec("Cdt", string(tag) + i32(len(data)) + data) for tag, data in blocks.items())))


def object_parameters(parameters: tuple[tuple[str, str, str], ...]) -> bytes:
    """CoppeliaSim 4.3's script simulation parameters kept with the object (``Lsp``)."""
    par = i32(len(parameters)) + b"".join(string(n) + string(u) + string(v) + i32(0) for n, u, v in parameters)
    return rec("Lsp", lst(rec("Par", par)))


def force_sensor(handle: int, parent: int, name: str, pos=(0, 0, 0), extra: bytes = b"", quat=(1, 0, 0, 0)) -> bytes:
    """A force sensor; ``quat``: its orientation in its parent's frame (w, x, y, z)."""
    return rec("FSE", common(handle, parent, name, pos, quat, extra=extra) + lst(rec("Siz", f32(0.02))))


def cuboid_shape(handle: int, parent: int, name: str, size=(0.1, 0.1, 0.1), pos=(0, 0, 0), mass=1.0,
                 dynamic=True, respondable=True, extra: bytes = b"", texture: bytes = b"",
                 colour: bytes | None = None, moments=(0.01, 0.01, 0.01), quat=(1, 0, 0, 0),
                 material: bytes = b"", primitive: int = 3) -> bytes:
    """A pure-cuboid shape (8 vertices inline, 12 triangles); ``texture``: its :func:`texture_link`;
    ``material``: its dynamic material (:func:`bullet_material`);
    ``colour``: its colour object (:func:`colour_object`; default an old ``Cl2`` of (0.2, 0.4, 0.6));
    ``moments``: its principal moments of inertia as V-REP stores them (divided by the mass);
    ``quat``: its orientation in its parent's frame (w, x, y, z); ``primitive``: the pure type
    the file names (3 cuboid, 5 cylinder: ``size`` x and z its diameter and height), its
    vertices staying the box's."""
    hx, hy, hz = (s / 2 for s in size)
    v = np.array([[x, y, z] for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)], "<f4")
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], "<i4")
    info = lst(rec("Nme", string(name)), rec("Mas", f32(mass)),
               rec("Ine", f32(0, 0, 0, 1, 0, 0, 0, *moments)))
    cl0 = colour if colour is not None else lst(rec("Cl2", f32(0.2, 0.4, 0.6, *([0.0] * 12))))
    mesh = lst(rec("Cl0", cl0),
               rec("Ver", v.tobytes()), rec("Ind", faces.tobytes()),
               rec("Ppr", struct.pack("<ifff", primitive, *size)), rec("Ppf", f32(0, 0, 0, 1, 0, 0, 0)), texture)
    typed = lst(rec("Ge2", lst(rec("Gst", info + mesh))),
                rec("Sss", bytes([0x80 if dynamic else 0])), rec("Ss3", bytes([1 if respondable else 0])),
                rec("Dc2", struct.pack("<H", 0xFFFF)), material)
    return rec("SHP", common(handle, parent, name, pos, quat, extra=extra) + typed)


def bullet_material(old: float, new: float | None = None) -> bytes:
    """A shape's dynamic material (``Mat``) with Bullet's two friction coefficients as
    ``CDynMaterialObject::serialize`` writes them: ``Bul`` (restitution, old friction, damping...)
    and, unless ``new`` is None (a file from before 2016), ``BuN`` (8 floats: restitution, old
    friction, friction, ...; 2 ints)."""
    items = [rec("Bul", f32(0.0, old, 0.0, 0.0, 0.1, 0.002))]
    if new is not None:
        items.append(rec("BuN", i32(8, 2) + f32(0.0, old, new, 0.0, 0.0, 0.1, 0.002, 0.0) + i32(4, 0)))
    return rec("Mat", lst(*items))


def plane_shape(handle: int, parent: int, name: str, size=(0.4, 0.6), pos=(0, 0, 0), wireframe: bool = True,
                respondable: bool = False, extra: bytes = b"") -> bytes:
    """A static V-REP plane (primitive 1: 4 vertices at z 0, 2 triangles, sizes x, y and V-REP's
    1e-4 z), drawn as lines (``Var`` bit 2) when ``wireframe``: RLBench's spawn boundaries."""
    hx, hy = size[0] / 2, size[1] / 2
    v = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], "<f4")
    faces = np.array([[0, 1, 2], [0, 2, 3]], "<i4")
    info = lst(rec("Nme", string(name)), rec("Mas", f32(1.0)), rec("Ine", f32(0, 0, 0, 1, 0, 0, 0, 0.01, 0.01, 0.01)))
    mesh = lst(rec("Cl0", lst(rec("Cl2", f32(0.2, 0.4, 0.6, *([0.0] * 12))))),
               rec("Ver", v.tobytes()), rec("Ind", faces.tobytes()),
               rec("Ppr", struct.pack("<ifff", 1, size[0], size[1], 1e-4)), rec("Ppf", f32(0, 0, 0, 1, 0, 0, 0)),
               rec("Var", bytes([4 if wireframe else 0])))
    typed = lst(rec("Ge2", lst(rec("Gst", info + mesh))), rec("Sss", bytes([0])),
                rec("Ss3", bytes([1 if respondable else 0])), rec("Dc2", struct.pack("<H", 0xFFFF)))
    return rec("SHP", common(handle, parent, name, pos, extra=extra) + typed)


def object_property(bits: int) -> bytes:
    """A common record: the object's ``sim.objectproperty_*`` bits (``Op2``)."""
    return rec("Op2", i32(bits))


def joint(handle: int, parent: int, name: str, pos=(0, 0, 0), quat=(1, 0, 0, 0), kind=10, position=0.0,
          motor=True, loop=True, max_force=10.0, target_velocity=0.0, extra: bytes = b"", mode: int = 5,
          limits=(-1.5, 3.0), cyclic: bool = False, common_extra: bytes = b"", spring: bool = False) -> bytes:
    """A joint in force/torque mode (``mode`` 5; 4: dependent, with a :func:`dependency` in
    ``extra``); ``limits``: V-REP's minimum and range; ``extra``: more typed records (``Dpc`` PID,
    ``Dtp`` target position, ``Spp`` spring K and C, ``Dcm`` 4.4 control mode); ``cyclic``: an
    unlimited revolute joint (``Va9`` bit 0); ``common_extra``: more common records (:func:`alias`);
    ``spring``: a <= 4.3 file's spring-damper mode (``Va9`` bit 7)."""
    va9 = (16 if motor else 0) | (32 if loop else 0) | (1 if cyclic else 0) | (128 if spring else 0)
    typed = lst(rec("Jtt", i32(kind)), rec("Jmd", i32(mode)), rec("Pmr", f32(*limits)), rec("Prt", f32(position)),
                rec("Va9", bytes([va9])), rec("Dmp", f32(target_velocity, max_force)), rec("Ulv", f32(2.0)), extra)
    return rec("JNT", common(handle, parent, name, pos, quat, extra=common_extra) + typed)


def dependency(master: int, mult: float, offset: float) -> bytes:
    """A joint's dependency record (``Jdt``: master handle, multiplier, offset, as V-REP stores
    them): q = offset + mult * q_master."""
    return rec("Jdt", struct.pack("<iff", master, mult, offset))


def dummy(handle: int, parent: int, name: str, pos=(0, 0, 0), linked=-1, link_type=0, extra: bytes = b"") -> bytes:
    return rec("DMY", common(handle, parent, name, pos, extra=extra) + lst(rec("Dy2", f32(0.02)), rec("Lli", i32(linked)),
                                                            rec("Dl2", i32(link_type))))


def light_encode(text: bytes) -> bytes:
    """V-REP's light script obfuscation (the inverse of the reader's decoding)."""
    buf = bytearray(text)
    n = len(buf)
    if n < 3:
        return bytes(buf)
    first = buf[0] - 256 if buf[0] > 127 else buf[0]
    last = buf[-1] - 256 if buf[-1] > 127 else buf[-1]
    start, end = int(first / 2), last * 3
    for i in range(1, n - 1):
        v = buf[i]
        if i & 1:
            v -= i + start + end
        if i & 2:
            v += 3 * i + start
        if i & 4:
            v -= i // 2 + end
        buf[i] = v % 256
    return bytes(buf)


def script(handle: int, obj: int, text: str, kind: int = 1, threaded: bool = False,
           parameters: tuple[tuple[str, str, str | bytes], ...] = (), language: str | None = None) -> bytes:
    """A script record (``LST``); ``parameters``: (name, unit, value) simulation parameters, a
    value of bytes stored unchanged; ``language``: CoppeliaSim 4.6's language marker (``Lne``:
    "python"), none for Lua."""
    par = i32(len(parameters)) + b"".join(string(n) + string(u) + string(v) + i32(0) for n, u, v in parameters)
    lne = rec("Lne", string(language)) if language is not None else b""
    return rec("LST", lst(rec("Si2", i32(handle, obj, kind)), rec("Va2", bytes([1 if threaded else 0])),
                          rec("Ste", light_encode(text.encode())), lne, rec("Prm", lst(rec("Par", par)))))


def huffman_encode(data: bytes) -> bytes:
    """The Basic Compression Library's Huffman format: tree (1 + 8-bit symbol = leaf, 0 = node
    then its "0" and "1" subtrees), then the codes, MSB first, padded to a byte."""
    counts = np.bincount(np.frombuffer(data, np.uint8), minlength=256)
    heap = [(int(c), s, s) for s, c in enumerate(counts) if c]
    heapq.heapify(heap)
    uid = 256
    children = {}
    if len(heap) == 1:
        root = heap[0][2]
    else:
        while len(heap) > 1:
            c1, _, a = heapq.heappop(heap)
            c2, _, b = heapq.heappop(heap)
            children[uid] = (a, b)
            heapq.heappush(heap, (c1 + c2, uid, uid))
            uid += 1
        root = heap[0][2]
    bits: list[str] = []
    codes: dict[int, str] = {}

    def walk(node, prefix):
        if node in children:
            bits.append("0")
            walk(children[node][0], prefix + "0")
            walk(children[node][1], prefix + "1")
        else:
            bits.append("1" + format(node, "08b"))
            codes[node] = prefix

    walk(root, "")
    table = [codes.get(s, "") for s in range(256)]
    stream = "".join(bits) + "".join(table[b] for b in data)
    stream += "0" * (-len(stream) % 8)
    return np.packbits(np.frombuffer(stream.encode(), np.uint8) - 48).tobytes()


def script_object(handle: int, parent: int, name: str, text: str, kind: int = 1, proxy: bool = False,
                  pos=(0, 0, 0), extra: bytes = b"", disabled: bool = False) -> bytes:
    """A CoppeliaSim 4.6+ script object (``SCT``, ``CScript::serialize``): the common part, then
    ``Sos`` size, ``Var``, and ``Soo``: the script's own records (``CDetachedScript::serialize``:
    ``Si2`` (0, object, type), ``Va2`` (bit 1: disabled), ``Va3`` (bit 2: parent is proxy), ``Ste`` with 4.6's
    ``--lua`` first line, ``Lne``)."""
    soo = lst(rec("Si2", i32(0, -1, kind)), rec("Va2", bytes([0xC8 | (2 if disabled else 0)])), rec("Va3", bytes([1 | (4 if proxy else 0)])),
              rec("Ste", light_encode(("--lua\n" + text).encode())), rec("Lne", string("lua")))
    typed = lst(rec("Sos", struct.pack("<d", 0.01)), rec("Var", bytes([0])), rec("Soo", soo))
    return rec("SCT", common(handle, parent, name, pos, extra=alias(name) + extra) + typed)


def collection(name: str, elements, handle: int = 2_000_000) -> bytes:
    """A collection (``GRP``): ``elements`` of (object handle or -1, V-REP's element type ``Gty``,
    additive)."""
    items = [rec("Asg", lst(rec("Obj", i32(h, i)), rec("Gty", bytes([kind])), rec("Var", bytes([int(add)]))))
             for i, (h, kind, add) in enumerate(elements)]
    return rec("GRP", lst(rec("Gix", i32(handle)), rec("Grn", string(name)), rec("Par", b"\0"), *items))


def ttt_file(body_records: bytes, serialization: int = 22, program: int = 40100, compress: bool = True) -> bytes:
    """A whole file: 1021-byte header + (Huffman-coded) body ending with EOF."""
    body = body_records + b"EOF"
    payload = huffman_encode(body) if compress else body
    header = b"VREP" + struct.pack("<iiBi", serialization, 18, 1 if compress else 0, len(body))
    header += struct.pack("<i", 0) + struct.pack("<H", program) + struct.pack("<I", 0x1001) + bytes([0, 1])
    return header.ljust(1021, b"\0") + payload


def simple_scene(port: int = 19999, **kw) -> bytes:
    """A static floor, a base, a revolute joint carrying a dynamic link with a tip dummy, a free
    cube, a child script on the link, and on the base a threaded script that opens the legacy
    remote API on ``port`` (a test that runs the scene gives a free port); two collections: the
    base's tree but the tip (``Arm``), everything but the cube (``NotCube``)."""
    return ttt_file(
        rec("SIM", lst(rec("Sts", f32(0.05)))) + rec("DYN", lst(rec("En2", i32(0) + f32(0, 0, -9.81)))) +
        cuboid_shape(1, -1, "Floor", (2, 2, 0.1), (0, 0, -0.05), dynamic=False) +
        cuboid_shape(2, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False) +
        joint(3, 2, "Base_joint1", (0, 0, 0.15), position=0.3) +
        cuboid_shape(4, 3, "Link#0", (0.05, 0.05, 0.4), (0, 0, 0.2), mass=0.5) +
        dummy(5, 4, "Tip", (0, 0, 0.2)) +
        cuboid_shape(6, -1, "Cube", (0.1, 0.1, 0.1), (0.6, 0, 0.3), mass=0.2) +
        collection("Arm", [(2, 1, True), (5, 0, False)]) +
        collection("NotCube", [(-1, 5, True), (6, 0, False)], 2_000_001) +
        script(100, 4, "function sysCall_init()\n  print('hi')\nend\n") +
        script(101, 2, f"simRemoteApi.start({port})\n", threaded=True, parameters=(("port", "int", str(port)),)) +
        script(102, 6, "function sysCall_init() end\n", kind=6), **kw)


def proximity_sensor(handle: int, parent: int, name: str, kind: int = 34, offset: float = 0.0, reach: float = 0.5,
                     sizes=(0.0,) * 6, angle: float = 0.0, pos=(0, 0, 0), faces: int | None = None) -> bytes:
    """A proximity sensor (``SNR``): V-REP's volume type ``Snt`` (30 pyramid, 31 cylinder, 32 disc,
    33 cone, 34 ray), its ``Ss3`` values (offset, range, x, y, x far, y far, radius, radius
    far, angle) and, given ``faces``, its ``Ssi`` (faceNumber, faceNumberFar, subdivisions,
    subdivisionsFar)."""
    volume = rec("Ss3", f32(offset, reach, *sizes, angle)) + (b"" if faces is None else rec("Ssi", i32(faces, 32, 0, 0)))
    typed = lst(rec("Snt", i32(kind)), rec("Vod", lst(volume)))
    return rec("SNR", common(handle, parent, name, pos) + typed)


def texture(tid: int, name: str, rgb: np.ndarray) -> bytes:
    """A top-level texture (``TEX``): ``rgb`` (h, w, 3) uint8, rows as the file keeps them."""
    h, w = rgb.shape[:2]
    return rec("TEX", lst(rec("Ipa", i32(tid, w, h)), rec("Gon", string(name)), rec("Img", rgb.astype(np.uint8).tobytes())))


def texture_link(tid: int, mode: int = 0, scale=(1.0, 1.0), frame=(1, 0, 0, 0, 0, 0, 0), apply: int = 0) -> bytes:
    """A mesh's texture (``Toj``) without fixed coordinates: V-REP's mapping ``mode`` (0 planar,
    3 cube), the texture's size ``scale`` (m) and its frame (qw qx qy qz x y z); ``apply`` how it
    meets the shape's colour (``Apm``: 0 modulate, 1 decal)."""
    return rec("Toj", lst(rec("Tob", struct.pack("<iiff", tid, mode, *scale)), rec("Trc", f32(*frame)),
                          rec("Ftc", b""), rec("Apm", i32(apply))))


def ik_group(name: str, elements, explicit: bool = False, enabled: bool = True, solver=None,
             precision=None, weights=None, max_steps: bool = False) -> bytes:
    """An old IK group (``IKO``): ``elements`` of (tip dummy, base, V-REP's constraint bits);
    ``Var`` as CoppeliaSim writes it (bit 0 enabled, bit 5 max step sizes, bit 6 explicit
    handling); ``solver`` (iterations, damping, method) as ``Mit``, ``_pg``, ``Cmt``; each
    element's ``precision`` (linear m, angular rad) as ``_r2`` (angular first) and ``weights``
    as ``_gt`` (CIkGroup_old / CIkElement_old::serialize)."""
    def element(tip, base, ctr):
        extra = [] if precision is None else [rec("_r2", struct.pack("<2d", precision[1], precision[0]))]
        extra += [] if weights is None else [rec("_gt", struct.pack("<2d", *weights))]
        return rec("Ike", lst(rec("Ik2", i32(tip, base)), rec("Ctr", i32(ctr)), *extra))
    items = [element(*e) for e in elements]
    if solver is not None:
        items = [rec("Mit", i32(solver[0])), rec("_pg", struct.pack("<d", solver[1])), rec("Cmt", i32(solver[2])),
                 *items]
    # "Var": bit 0 active, bit 6 explicit handling (CIkGroup::serialize); "Va2" bit 0: joint-limit correction
    var = (0x40 if explicit else 0) | (0x01 if enabled else 0) | (0x20 if max_steps else 0)
    return rec("IKO", lst(rec("Nme", string(name)), rec("Var", bytes([var])), rec("Va2", b"\x01"), *items))


def colour_object(diffuse=(0.7, 0.7, 0.7), specular=(0.25, 0.25, 0.25), emission=(0.0, 0.0, 0.0),
                  shininess: int = 48, light=(0.0, 0.0, 0.0), opacity: float | None = None) -> bytes:
    """A colour object (CColorObject) as V-REP 3.1.3+ writes it: ``Cl3`` the 15 colours
    (ambient-diffuse, light diffuse, specular, emission, auxiliary), ``Sh2`` shininess, ``Trf``
    opacity and ``Var`` (bit 2 clear: translucent, when ``opacity`` is given)."""
    colours = f32(*diffuse, *light, *specular, *emission, 0.5, 0.0, 0.0)
    var = bytes([0 if opacity is not None else 4])
    return lst(rec("Cl3", colours), rec("Sh2", i32(shininess)), rec("Trf", f32(opacity or 0.5)), rec("Var", var))


def light(handle: int, parent: int, name: str, kind: int = 3, diffuse=(0.5, 0.5, 0.5), specular=(0.5, 0.5, 0.5),
          pos=(0, 0, 0), quat=(1, 0, 0, 0), active: bool = True, local: bool = False,
          attenuation=(0.25, 0.0, 0.1), cutoff: float = 1.0) -> bytes:
    """A light (``LGT``): V-REP's type (1 omnidirectional, 2 spot, 3 directional: along its +z),
    its colours, ``Cas`` bits (0 active, 1 local), attenuation and spot cut-off (rad)."""
    typed = lst(rec("Cp2", struct.pack("<iif", kind, 5, 0.1)), rec("Cp3", f32(cutoff)), rec("Caf", f32(*attenuation)),
                rec("Cas", bytes([int(active) | 2 * int(local)])),
                rec("Cl2", colour_object((0, 0, 0), specular, light=diffuse)))
    return rec("LGT", common(handle, parent, name, pos, quat) + typed)


def camera_sensor(handle: int, parent: int, name: str, resolution=(64, 64), ortho_size: float = 1.0,
                  pos=(0, 0, 0), quat=(1, 0, 0, 0), perspective: bool = False, angle: float = 1.0,
                  near: float = 0.01, far: float = 5.0) -> bytes:
    """A vision sensor (``RSN``) looking along its +z: ``Ccp`` (ortho size, view angle, near,
    far), ``Res``, ``Va3`` bit 0 perspective."""
    typed = lst(rec("Ccp", f32(ortho_size, angle, near, far)), rec("Res", i32(*resolution)),
                rec("Va3", bytes([int(perspective)])))
    return rec("RSN", common(handle, parent, name, pos, quat) + typed)


def environment(ambient=None, old_ambient=None, fog: bool = False) -> bytes:
    """The environment (``ENV``): ``Al2`` the ambient light, ``Alc`` its older half-value twin,
    ``Var`` bit 4 fog."""
    records = [rec("Var", bytes([16 if fog else 0]))]
    if ambient is not None:
        records.append(rec("Al2", f32(*ambient)))
    if old_ambient is not None:
        records.append(rec("Alc", f32(*old_ambient)))
    return rec("ENV", lst(*records))


def simulation(time_step: float, preset: int = 5, real_time: bool | None = None, factor: float = 1.0,
               double: bool = False) -> bytes:
    """The simulation settings (``SIM``): the step as V-REP 3.x writes it (``Sts`` f32 and the
    preset index ``Spi``, 5 = custom) or, with ``double``, as 4.5 does (``_t3`` f64 too);
    real-time mode (``Ss2`` bit 0) and its multiplier (``Rtc``), left out when ``real_time`` is None."""
    items = [rec("Sts", f32(time_step)), rec("Spi", i32(preset))]
    if double:
        items.append(rec("_t3", struct.pack("<d", time_step)))
    if real_time is not None:
        items += [rec("Ss2", bytes([1 if real_time else 0])), rec("Rtc", f32(factor))]
    return rec("SIM", lst(*items))


def dynamics(gravity=(0, 0, -9.81), engine: int = 0, step: float | None = None, version: int | None = None) -> bytes:
    """The engine record (``En2``: engine, gravity, settings mode), with ``step`` the 4.5
    physics step ``_tp``, with ``version`` the engine version ``Ver`` (Bullet: 0 2.78, 283 2.83)."""
    items = [rec("En2", i32(engine) + f32(*gravity) + i32(4))]
    if version is not None:
        items.append(rec("Ver", i32(version)))
    if step is not None:
        items.append(rec("_tp", struct.pack("<d", step)))
    return rec("DYN", lst(*items))


def collision_object(name: str, entity1: int, entity2: int, handle: int = 1) -> bytes:
    """A V-REP collision object (``COL``): entities are object or collection handles, entity2 -1
    = all other objects."""
    return rec("COL", lst(rec("Inx", i32(entity1, entity2, handle)), rec("Nme", string(name)),
                          rec("Var", bytes([0]))))


def distance_object(name: str, entity1: int, entity2: int, handle: int = 1, threshold: float | None = None) -> bytes:
    """A V-REP distance object (``DST``), with ``threshold`` (m) enabled when given."""
    var = rec("Var", bytes([1 if threshold is not None else 0]))
    items = [rec("Inx", i32(entity1, entity2, handle)), rec("Nme", string(name)), var]
    if threshold is not None:
        items.append(rec("_rh", struct.pack("<d", threshold)))
    return rec("DST", lst(*items))


def mesh_pool(vertices: np.ndarray, indices: np.ndarray | bytes) -> bytes:
    """The shared mesh pool (``VIN``): one vertex array (``Ver``, (N, 3) float32) and one index
    array (``Ind`` int32, or ``In2`` when ``indices`` are packed bytes, :func:`packed`)."""
    ind = rec("In2", indices) if isinstance(indices, bytes) else rec("Ind", np.asarray(indices, "<i4").tobytes())
    return rec("VIN", lst(rec("Ver", np.asarray(vertices, "<f4").tobytes()), ind))


def pool_shape(handle: int, parent: int, name: str, vertex_array: int = 0, index_array: int = 0,
               pos=(0, 0, 0)) -> bytes:
    """A static mesh shape whose triangles are pool arrays (``Vev``/``Inv`` indices into ``VIN``)."""
    info = lst(rec("Nme", string(name)), rec("Mas", f32(1.0)), rec("Ine", f32(0, 0, 0, 1, 0, 0, 0, 0.01, 0.01, 0.01)))
    mesh = lst(rec("Vev", i32(vertex_array)), rec("Inv", i32(index_array)), rec("Ppf", f32(0, 0, 0, 1, 0, 0, 0)))
    typed = lst(rec("Ge2", lst(rec("Gst", info + mesh))), rec("Sss", bytes([0])), rec("Ss3", bytes([1])))
    return rec("SHP", common(handle, parent, name, pos) + typed)


def packed(values) -> bytes:
    """V-REP's packed index array (``In2``): i32 count, then each delta to the previous value in
    1 to 4 bytes (top 2 bits of the first: how many follow; biased)."""
    out = bytearray(struct.pack("<i", len(values)))
    prev = 0
    for v in values:
        d, prev = int(v) - prev, int(v)
        for n, bias in enumerate((31, 8191, 2097151, 536870911)):
            x = d + bias
            if 0 <= x < (1 << (6 + 8 * n)):
                out.append((x & 0x3F) | (n << 6))
                out.extend((x >> (6 + 8 * k)) & 0xFF for k in range(n))
                break
    return bytes(out)
