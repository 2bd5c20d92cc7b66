"""CoppeliaSim 4.x's image and buffer utilities, referenced handles, alternate configurations and
saving the scene as MJCF (``sim.getScaledImage``, ``sim.transformImage``, ``sim.getReferencedHandles``,
``sim.getAlternateConfigs``, ``sim.saveScene``, ``sim.saveModel`` ...).

Images are uint8 RGB buffers, rows bottom-up, as ``getVisionSensorImg`` returns them; scaling is
OpenCV's. ``saveScene`` / ``saveModel`` write MJCF (``MjSpec.to_xml``): a client (and a script it
calls, and a scene it sent) writes a ``.xml`` file by a relative name into its own folder, within
its budget; the operator's scripts write in the server's scene folder or a ``--scene-path``
folder, never in a transfer folder (:mod:`simx_server.scene.client_files`). ``saveScene`` writes
the files the scene names next to it (meshes and textures held in memory, scripts, custom data:
:mod:`simx_server.scene.scene_file`), so that the saved scene loads back.
"""

from __future__ import annotations

import base64
import itertools
from pathlib import Path
from typing import Any

import cv2
import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import file_writes, sensors as _sensors
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim.objects import JOINT

_BUFFER = {0: np.uint8, 1: np.int8, 2: np.uint16, 3: np.int16, 4: np.uint32, 5: np.int32, 6: np.float32, 7: np.float64}
MAX_IMAGE_SIDE = 8192


def _image(image: Any, resolution: Any, channels: int = 3) -> np.ndarray:
    w, h = (_int(v, "resolution[i]") for v in resolution)
    raw = _bytes(image, "image")
    if not (0 < w <= MAX_IMAGE_SIDE and 0 < h <= MAX_IMAGE_SIDE) or len(raw) != w * h * channels:
        raise ArgumentError(f"image must hold {w}x{h}x{channels} bytes (resolution at most {MAX_IMAGE_SIDE})")
    return np.frombuffer(raw, np.uint8).reshape(h, w, channels)


#: Most configurations getAlternateConfigs answers (whole turns multiply them joint by joint).
MAX_ALTERNATE_CONFIGS = 10_000


def alternate_configs(m: mujoco.MjModel, joints: list, config: list[float], lowLimits: Any = None,  # noqa: N803
                      ranges: Any = None) -> list[float]:
    """``config`` (one position per joint of ``joints``, scene objects) and the configurations
    equal to it up to whole turns of its revolute joints within their ranges (or ``lowLimits`` /
    ``ranges``), flat, configuration after configuration, at most MAX_ALTERNATE_CONFIGS of them
    (``sim.getAlternateConfigs``, ``simIK.getAlternateConfigs``).

    Args:
        m: the scene's MuJoCo model.
        joints: the joints' scene objects.
        config: one position per joint (rad or m).
        lowLimits: one lower limit per joint (rad or m), or None.
        ranges: one range per joint, or None.

    Returns:
        n * len(joints) floats.

    Raises:
        ArgumentError: limits that are not numbers.
    """
    choices = []
    for i, (obj, q) in enumerate(zip(joints, config)):
        lo, hi = (m.jnt_range[obj.mj_id] if m.jnt_limited[obj.mj_id] else (-np.inf, np.inf))
        if lowLimits is not None and ranges is not None:
            lo, hi = _num(lowLimits[i], "lowLimits[i]"), _num(lowLimits[i], "lowLimits[i]") + _num(ranges[i], "ranges[i]")
        if int(m.jnt_type[obj.mj_id]) == mujoco.mjtJoint.mjJNT_HINGE and np.isfinite(lo) and np.isfinite(hi):
            ks = range(int(np.ceil((lo - q) / (2 * np.pi))), int(np.floor((hi - q) / (2 * np.pi))) + 1)
            choices.append([q + 2 * np.pi * k for k in ks] or [q])
        else:
            choices.append([q])
    combos = itertools.islice(itertools.product(*choices), MAX_ALTERNATE_CONFIGS)
    return [float(v) for combo in combos for v in combo]


# Image utilities, referenced handles, alternate configurations, saving.

@sim_function("getScaledImage")
def getScaledImage(ctx: CallContext, imageIn: Any, resolutionIn: Any, desiredResolutionOut: Any,  # noqa: N802, N803
                   options: Any = 0) -> tuple[bytes, list[int]]:
    """``imageOut, effectiveResolutionOut``: an RGB image resized (OpenCV, area averaging
    down, linear up); ``options`` bit 0: keep the aspect ratio inside the desired size.

    ``sim.getScaledImage``.

    Args:
        imageIn: w*h*3 bytes, RGB.
        resolutionIn: ``[w, h]``, pixels.
        desiredResolutionOut: ``[w, h]``, pixels.
        options: bit 0: keep the aspect ratio.

    Returns:
        ``(imageOut, effectiveResolutionOut)``: RGB bytes and ``[w, h]``.

    Raises:
        ArgumentError: an image that does not match its resolution, or a size out of range.
    """
    img = _image(imageIn, resolutionIn)
    w, h = (_int(v, "desiredResolutionOut[i]") for v in desiredResolutionOut)
    if not (0 < w <= MAX_IMAGE_SIDE and 0 < h <= MAX_IMAGE_SIDE):
        raise ArgumentError(f"desiredResolutionOut must lie in 1..{MAX_IMAGE_SIDE}")
    if _int(options, "options") & 1:
        f = min(w / img.shape[1], h / img.shape[0])
        w, h = max(1, round(img.shape[1] * f)), max(1, round(img.shape[0] * f))
    shrink = w < img.shape[1] or h < img.shape[0]
    out = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)
    return np.ascontiguousarray(out).tobytes(), [w, h]


@sim_function("transformImage")
def transformImage(ctx: CallContext, image: Any, resolution: Any, options: Any) -> bytes:  # noqa: N802
    """The RGB image transformed: ``options`` bit 0 swaps red and blue, bit 1 flips it
    vertically, bit 2 horizontally.

    ``sim.transformImage``.

    Args:
        image: w*h*3 bytes, RGB.
        resolution: ``[w, h]``, pixels.
        options: bits 0-2.

    Returns:
        The RGB bytes.

    Raises:
        ArgumentError: an image that does not match its resolution.
    """
    img = _image(image, resolution).copy()
    opts = _int(options, "options")
    if opts & 1:
        img = img[:, :, ::-1]
    if opts & 2:
        img = img[::-1]
    if opts & 4:
        img = img[:, ::-1]
    return np.ascontiguousarray(img).tobytes()


@sim_function("combineRgbImages")
def combineRgbImages(ctx: CallContext, img1: Any, img1Res: Any, img2: Any, img2Res: Any, operation: Any) -> bytes:  # noqa: N802, N803
    """``sim.imgcomb_vertical`` (0: img2 above img1, rows bottom-up) or ``imgcomb_horizontal``
    (1: side by side) of two RGB images of matching size.

    ``sim.combineRgbImages``.

    Args:
        img1: w*h*3 bytes, RGB.
        img1Res: ``[w, h]``, pixels.
        img2: w*h*3 bytes, RGB.
        img2Res: ``[w, h]``, pixels.
        operation: 0 or 1.

    Returns:
        The combined RGB bytes.

    Raises:
        ArgumentError: an unknown operation, sizes that do not match, or a bad image.
    """
    a, b = _image(img1, img1Res), _image(img2, img2Res)
    op = _int(operation, "operation")
    if op not in (0, 1) or a.shape[1 - op] != b.shape[1 - op]:
        raise ArgumentError("operation 0 (vertical: same widths) or 1 (horizontal: same heights)")
    return np.ascontiguousarray(np.concatenate([a, b], axis=op)).tobytes()


@sim_function("transformBuffer")
def transformBuffer(ctx: CallContext, inBuffer: Any, inFormat: Any, multiplier: Any, offset: Any, outFormat: Any) -> bytes:  # noqa: N802, N803
    """A buffer of ``sim.buffer_*`` items (uint8 ... double), each ``value * multiplier +
    offset``, as another type (``outFormat`` + ``sim.buffer_clamp``: clamped to its range).

    ``sim.transformBuffer``.

    Args:
        inBuffer: bytes of ``inFormat`` items.
        inFormat: ``sim.buffer_*`` (0-7).
        multiplier: factor.
        offset: added after the factor.
        outFormat: ``sim.buffer_*``, plus ``sim.buffer_clamp`` (256) to clamp.

    Returns:
        The bytes of ``outFormat`` items.

    Raises:
        UnsupportedError: a format out of 0-7.
        ArgumentError: a bad argument.
    """
    src, dst = _int(inFormat, "inFormat"), _int(outFormat, "outFormat")
    clamp, dst = bool(dst & 256), dst & ~256
    if src not in _BUFFER or dst not in _BUFFER:
        raise UnsupportedError("transformBuffer formats: sim.buffer_uint8 ... buffer_double (0-7)")
    raw = _bytes(inBuffer, "inBuffer")
    size = np.dtype(_BUFFER[src]).itemsize
    values = np.frombuffer(raw[:len(raw) // size * size], _BUFFER[src]).astype(np.float64)
    values = values * _num(multiplier, "multiplier") + _num(offset, "offset")
    kind = _BUFFER[dst]
    if clamp and np.issubdtype(kind, np.integer):
        info = np.iinfo(kind)
        values = np.clip(values, info.min, info.max)
    return values.astype(kind).tobytes()


@sim_function("getVisionSensorDepthBuffer")
def getVisionSensorDepthBuffer(ctx: CallContext, sensorHandle: Any, pos: Any = None, size: Any = None) -> list[float]:  # noqa: N802, N803
    """The depth buffer as a table of floats 0..1 (near to far clipping plane), rows
    bottom-up; ``sensorHandle + sim.handleflag_depthbuffermeters``: distances in m.

    ``sim.getVisionSensorDepthBuffer``.

    Args:
        sensorHandle: a vision sensor's handle (plus ``sim.handleflag_depthbuffermeters``).
        pos: must be None.
        size: must be None.

    Returns:
        w*h floats, 0..1 (or m).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        UnsupportedError: a window (``pos``/``size``), or no simulation behind the script.
    """
    h = ctx.h(sensorHandle, "sensorHandle")
    metres = h >= 0 and bool(h & 0x800000)  # sim.handleflag_depthbuffermeters
    if metres:
        h &= ~0x800000
    if pos is not None or size is not None:
        raise UnsupportedError("getVisionSensorDepthBuffer of a window: use getVisionSensorDepth(h, options, pos, size)")
    job = _sensors.depth_job(ctx, "getVisionSensorDepthBuffer", ctx.h(h), metres)
    return _sensors.rendered(ctx, "getVisionSensorDepthBuffer", lambda: job().astype(np.float64).reshape(-1).tolist())


def _refs(ctx: CallContext, handle: Any) -> dict[str, list[int]]:
    """The object's referenced handles, tag -> handles; first seeded from the scene's
    ``refs.TAG=NAME,NAME`` settings (a converted ``.ttt``'s, :mod:`simx_server.scene.ttt.custom`)."""
    holder = ctx.holder
    store = getattr(holder, "referenced_handles", None)
    if store is None:
        store = holder.referenced_handles = {}
    obj = ctx.world.get(ctx.h(handle))
    refs = store.get(obj.handle)
    if refs is None:
        refs = store[obj.handle] = {}
        for key, value in obj.settings.items():
            if key == "refs" or key.startswith("refs."):
                found = [ctx.world.by_name.get(n) for n in value.split(",")]
                refs[key[5:]] = [o.handle for o in found if o is not None]
    return refs


@sim_function("setReferencedHandles")
def setReferencedHandles(ctx: CallContext, objectHandle: Any, referencedHandles: Any, tag: Any = "") -> None:  # noqa: N802, N803
    """Store handles that ``objectHandle`` refers to under ``tag`` (any scene objects).

    ``sim.setReferencedHandles``.

    Args:
        objectHandle: the referring object.
        referencedHandles: list of handles (the first 10,000 kept).
        tag: the tag (``""``: the default one).

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.
    """
    refs = [ctx.world.get(ctx.h(h, "referencedHandles[i]")).handle for h in referencedHandles]
    _refs(ctx, objectHandle)[_text(tag, "tag")] = refs[:10_000]


@sim_function("addReferencedHandle")
def addReferencedHandle(ctx: CallContext, objectHandle: Any, referencedHandle: Any, tag: Any = "", opts: Any = None) -> None:  # noqa: N802, N803
    """``sim.addReferencedHandle``: add one handle under ``tag`` (once; at most 10,000).

    Args:
        objectHandle: the referring object.
        referencedHandle: the handle to add.
        tag: the tag (``""``: the default one).
        opts: ignored.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.

    """
    refs = _refs(ctx, objectHandle).setdefault(_text(tag, "tag"), [])
    h = ctx.world.get(ctx.h(referencedHandle, "referencedHandle")).handle
    if h not in refs and len(refs) < 10_000:
        refs.append(h)


@sim_function("getReferencedHandles")
def getReferencedHandles(ctx: CallContext, objectHandle: Any, tag: Any = "") -> list[int]:  # noqa: N802, N803
    """The handles stored under ``tag``, those still in the scene (-1 for a removed one).

    ``sim.getReferencedHandles``.

    Args:
        objectHandle: the referring object.
        tag: the tag (``""``: the default one).

    Returns:
        The handles.

    Raises:
        UnknownObjectError: no such object.
    """
    return [h if h in ctx.world.objects else -1 for h in _refs(ctx, objectHandle).get(_text(tag, "tag"), [])]


@sim_function("getReferencedHandle")
def getReferencedHandle(ctx: CallContext, objectHandle: Any, tag: Any = "") -> int:  # noqa: N802, N803
    """``sim.getReferencedHandle``: the first handle stored under ``tag``.

    Args:
        objectHandle: the referring object.
        tag: the tag (``""``: the default one).

    Returns:
        The handle, or -1 (none, or removed).

    Raises:
        UnknownObjectError: no such object.

    """
    refs = getReferencedHandles(ctx, objectHandle, tag)
    return refs[0] if refs else -1


@sim_function("getReferencedHandlesTags")
def getReferencedHandlesTags(ctx: CallContext, objectHandle: Any) -> list[str]:  # noqa: N802, N803
    """``sim.getReferencedHandlesTags``: the tags the object stores handles under.

    Args:
        objectHandle: the referring object.

    Returns:
        The tags, sorted.

    Raises:
        UnknownObjectError: no such object.

    """
    return sorted(_refs(ctx, objectHandle))


@sim_function("getAlternateConfigs")
def getAlternateConfigs(ctx: CallContext, jointHandles: Any, inputConfig: Any, tipHandle: Any = -1,  # noqa: N802, N803
                        lowLimits: Any = None, ranges: Any = None) -> list[float]:
    """``inputConfig`` and the configurations equal to it up to whole turns of revolute
    joints within their ranges (or ``lowLimits`` / ``ranges``), flat; the tip's pose is the
    same in each (``tipHandle`` only checked).

    ``sim.getAlternateConfigs``.

    Args:
        jointHandles: n joint handles.
        inputConfig: n positions (rad or m).
        tipHandle: checked only.
        lowLimits: n lower limits, or None.
        ranges: n ranges, or None.

    Returns:
        k * n floats.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint.
        ArgumentError: lengths that differ.
    """
    m = ctx.world.model
    joints = [ctx.world.get(ctx.h(j, "jointHandles[i]"), JOINT) for j in jointHandles]
    config = [_num(v, "inputConfig[i]") for v in inputConfig]
    if len(config) != len(joints):
        raise ArgumentError("inputConfig must have one value per joint")
    return alternate_configs(m, joints, config, lowLimits, ranges)


def target_file(ctx: CallContext, filename: Any, what: str = "saveScene") -> tuple[Path, str | None]:
    """``(file, writer)``: where a file call writes ``filename`` (a ``.xml`` name) and who
    writes it (:meth:`ClientFiles.writer <simx_server.scene.client_files.ClientFiles.writer>`:
    a client, in its own folder; the operator's scripts, in the scene folders)."""
    sim = ctx.simulation(what)
    name = _text(filename, "filename")
    if not name or "\x00" in name or not name.lower().endswith(".xml"):
        raise ArgumentError("simx saves MJCF: give a .xml file name")
    files = sim.editor.files
    key = files.writer(script_path(ctx))
    return files.target(name, key, f"sim.{what}"), key


def script_path(ctx: CallContext) -> Path | None:
    """The calling script's file (None: a ZMQ door's clients), for :meth:`ClientFiles.writer`."""
    script = ctx.script
    return getattr(script, "path", None) if script is not None else None


@sim_function("saveScene")
def saveScene(ctx: CallContext, filename: Any) -> None:  # noqa: N802
    """Write the scene as it is now (its MjSpec with the edits, its objects where they are) as
    MJCF, with the files it names next to it (``<stem>_...``: meshes, textures, scripts, custom
    data; :mod:`simx_server.scene.scene_file`): a client's into its own folder, the operator's
    scripts' into the scene folders (see the module's text). The file loads back as the scene.

    ``sim.saveScene``.

    Args:
        filename: a ``.xml`` name (a client: relative, in its own folder).

    Raises:
        ArgumentError: not a ``.xml`` name; a client's name outside its folder.
        RemoteError: the operator's file outside the scene folders; past the client's
            budget (``MAX_CLIENT_FILES_BYTES``, ``MAX_TRANSFER_FOLDER_BYTES``).
        UnsupportedError: MuJoCo cannot write the scene, or no simulation behind the script.
    """
    file, key = target_file(ctx, filename)
    files = ctx.simulation("saveScene").editor.files
    extra, text = ctx.simulation("saveScene").editor.prepare_save(file.stem)
    name = str(filename)
    writes = []
    for sibling, data in extra.items():  # meshes, scripts, data: next to the scene, within the same bounds
        other = str(Path(name).with_name(sibling))
        writes.append((files.target(other, key, "sim.saveScene"), data, other))
    return file_writes.write_files(ctx, key, lambda: [*writes, (file, text().encode("utf-8"), name)])


@sim_function("saveModel")
def saveModel(ctx: CallContext, modelBaseHandle: Any, filename: Any) -> None:  # noqa: N802, N803
    """Write the body subtree of a shape (a model) as an MJCF file of its own.

    ``sim.saveModel``.

    Args:
        modelBaseHandle: a shape's handle.
        filename: a ``.xml`` name, as :func:`saveScene`'s.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a shape, or not a ``.xml`` name; a client's name outside its folder.
        RemoteError: as :func:`saveScene`.
        UnsupportedError: MuJoCo cannot write the model, or no simulation behind the script.
    """
    file, key = target_file(ctx, filename, "saveModel")
    obj = ctx.world.get(ctx.h(modelBaseHandle))
    if obj.type != 0:
        raise ArgumentError(f"{obj.name!r} is not a shape (a body) to save as a model")
    extra, text = ctx.simulation("saveModel").editor.prepare_model_save(obj.name, file.stem)
    name = str(filename)
    files = ctx.simulation("saveModel").editor.files
    writes = [(files.target(other, key, "sim.saveModel"), data, other)
              for other, data in ((str(Path(name).with_name(n)), d) for n, d in extra.items())]
    return file_writes.write_files(ctx, key, lambda: [*writes, (file, text().encode("utf-8"), name)])




def _value_of_key(key: str, text: str) -> str | None:
    """``tt::getValueOfKey``: in ``key1 {value1} key2 {value2 {nested}}``, the value of ``key``
    (``a@b``: key ``a`` inside the value of ``b``), None when absent."""
    for part in reversed(key.split("@")):
        pairs, rest = {}, text
        while "{" in rest:
            p1, depth = rest.index("{"), 0
            for p2 in range(p1, len(rest)):
                depth += {"{": 1, "}": -1}.get(rest[p2], 0)
                if depth == 0:
                    break
            else:
                break
            pairs.setdefault(rest[:p1].strip(), rest[p1 + 1:p2].strip())
            rest = rest[p2 + 1:]
        text = pairs.get(part, "")
        if not text:
            return None
    return text


@sim_function("getExtensionString")
def getExtensionString(ctx: CallContext, objectHandle: Any, index: Any, key: Any = None) -> str | None:  # noqa: N802, N803
    """An object's extension string as the ``.ttt`` stored it (``extension=`` setting), or the
    value of ``key`` in it (``povray@...``), as coppeliaSimLib ``simGetExtensionString_internal``;
    None (Lua nil) when empty or absent. The scene's own (``objectHandle`` -1) and a shape's
    mesh colours' (``index`` >= 0) are not read from the file: UnsupportedError.

    Args:
        objectHandle: an object's handle.
        index: -1 (the object's own string).
        key: a key, or None / "" for the whole string.

    Returns:
        The text, or None.

    Raises:
        UnknownObjectError: no such object.
        UnsupportedError: the scene's or a mesh colour's string.
    """
    h, i = _int(objectHandle, "objectHandle"), _int(index, "index")
    if h == -1 or (i >= 0 and ctx.world.get(ctx.h(h)).type == C.sim_object_shape_type):
        raise UnsupportedError("getExtensionString: simx keeps objects' extension strings only (not the "
                               "scene's, nor a shape's mesh colours')")
    raw = ctx.world.get(ctx.h(h)).settings.get("extension", "")
    text = base64.urlsafe_b64decode(raw + "=" * (-len(raw) % 4)).decode("utf-8", "replace") if raw else ""
    if text and key:
        return _value_of_key(_text(key, "key"), text)
    return text or None
