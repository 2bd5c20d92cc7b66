"""Bullet's friction between two shapes: the product of their coefficients.

V-REP and CoppeliaSim 4.1 step their scenes with Bullet 2.78 by default, which gives a contact
between two bodies the product of their friction coefficients, at most 10
(``btManifoldResult::calculateCombinedFriction``, ``MAX_FRICTION``; simExtDynamics hands each
shape its material's coefficient). MuJoCo gives a contact the larger of its two geoms' values.
The ``.ttt`` converter stores a shape's coefficient squared as its geoms' sliding friction
(:mod:`simx_server.scene.ttt.geoms`), so two shapes of one material get Bullet's value either way;
two different materials do not: a ball of coefficient 0.1 on a table of 0.71 (RLBench's
hit_ball_with_queue) slides on Bullet's 0.071 and on MuJoCo's 0.5041.

A scene that declares Bullet's rule (``<custom><text name="simx:scene:friction"
data="combine=product"/></custom>``: every converted ``.ttt`` scene, PyRep's empty scene) gets it
for every contact between two geoms of different sliding friction (and equal ``priority``, a
MuJoCo setting V-REP has not): between ``mj_step1`` and ``mj_step2`` of each substep, the
contact's sliding friction becomes ``sqrt(f1 * f2)`` (= the product of the two coefficients) and
its regularised cone's ``mu`` scales with it (MuJoCo's ``mj_makeImpedance`` sets ``mu =
friction[0] * sqrt(R1 / R0)``); with the elliptic cone the rows' Jacobian does not depend on the
friction and, for ``condim`` 3, nor does their regularisation ``R``; the torsional and rolling
rows' ``R`` (``condim`` 4 and 6) are set again as ``mj_makeImpedance`` sets them. The state a
client reads after a step (:func:`forward`) is computed the same way. For the substeps of a
step (:func:`steps`), the geoms on the larger side of the contacts it starts with carry those
contacts' product as their sliding friction, so that MuJoCo gives them Bullet's value itself and
only the other contacts are changed. A scene whose geoms share one friction value, and one with
MuJoCo's pyramidal cone (whose rows are built from the friction), step inside MuJoCo as before.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from simx_server.sim.kept import PerObject, entry
from simx_server.sim.objects import parse_settings, text_of

__all__ = ["BULLET_MAX_FRICTION", "DEFAULT_COEFFICIENT", "TEXT", "applies", "combine", "declared", "forward", "mixed",
           "new_shape", "steps"]

TEXT = "simx:scene:friction"
#: Bullet 2.78's cap on a combined friction coefficient (``MAX_FRICTION``).
BULLET_MAX_FRICTION = 10.0
#: The friction coefficient of a shape made at run time in CoppeliaSim 4.1: its default material's
#: Bullet 2.78 value (coppeliaSimLib ``CDynMaterialObject::setDefaultValues``).
DEFAULT_COEFFICIENT = 0.71
_ELLIPTIC = int(mujoco.mjtCone.mjCONE_ELLIPTIC)
_ENERGY = int(mujoco.mjtEnableBit.mjENBL_ENERGY)
_OVERRIDE = int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
_POSITION_STAGE = int(mujoco.mjtStage.mjSTAGE_POS)


def declared(model: mujoco.MjModel) -> bool:
    """Whether the scene asks for Bullet's product of coefficients (``simx:scene:friction``,
    ``combine=product``; ``combine=max``, or no such text, keeps MuJoCo's larger value) and has
    the elliptic cone it needs.

    Args:
        model: the compiled scene.

    Returns:
        True when :func:`combine` applies to the scene's contacts.

    Raises:
        ValueError: a ``combine`` other than ``product`` or ``max`` (the scene is refused when it
            loads).
    """
    return _text(model) == "product" and int(model.opt.cone) == _ELLIPTIC


def _text(model: mujoco.MjModel) -> str:
    """The scene's ``combine=`` (``max`` without the text); ValueError for another value."""
    raw = text_of(model, TEXT)
    return "max" if raw is None else _combine(raw)


def _combine(raw: str) -> str:
    """The ``combine=`` of the text's data ``raw`` (``max`` by default); ValueError for another
    value or an item that is not ``key=value``."""
    combine_as = parse_settings(raw).get("combine", "max")
    if combine_as not in ("product", "max"):
        raise ValueError(f"custom text {TEXT!r}: combine={combine_as[:40]!r} is not 'product' or 'max'")
    return combine_as


class _Kept:
    """What this module keeps per compiled model: read once, its facts; kept while the model's
    frictions are the same, the answers of :func:`mixed`, :func:`combine` and :func:`_lowered`.
    A model that is gone (a scene replaced, a rebuild) drops out with its own."""

    __slots__ = ("rule", "special", "wide", "mixed", "answers", "lowered", "sliding", "contype", "conaffinity")

    def __init__(self, model: mujoco.MjModel):
        #: The model's arrays read at every step (each attribute of MuJoCo's bindings builds a new
        #: ndarray; these do not keep the model alive): the geoms' sliding frictions (a column
        #: view of ``geom_friction``), ``geom_contype``, ``geom_conaffinity``.
        self.sliding, self.contype, self.conaffinity = model.geom_friction[:, 0], model.geom_contype, model.geom_conaffinity
        try:
            rule = _text(model) == "product"
        except ValueError:  # the scene's load reports it
            rule = False
        #: The scene declares Bullet's rule (:func:`declared`'s text).
        self.rule = rule
        #: It has flexes, explicit pairs or geom priorities (:func:`_mujocos_own`).
        self.special = bool(model.nflex or model.npair) or bool(model.geom_priority.any())
        #: It has a geom of ``condim`` > 3 (torsional and rolling rows).
        self.wide = bool(model.ngeom) and int(model.geom_condim.max()) > 3
        #: :func:`mixed`'s last answer: (the frictions and contact bits it read, as bytes, the answer).
        self.mixed: tuple[bytes, bool] = (b"", False)
        #: {the key of the frictions MuJoCo read (:func:`_frictions`, the lowered values after
        #: it): {the contacts' geoms as bytes: :func:`_answer`'s answer}}.
        self.answers: dict[bytes, dict[bytes, tuple]] = {}
        #: {:func:`_frictions`: ({the contacts' geoms as bytes: :func:`_lower`'s answer},
        #: [the last answer that was not None])}.
        self.lowered: dict[bytes, tuple[dict[bytes, tuple | None], list]] = {}


#: ``model``'s :class:`_Kept`.
_kept: Callable[[mujoco.MjModel], _Kept] = PerObject(_Kept)


def _whole_buffer(start: np.ndarray, d: mujoco.MjData, writeable: bool) -> np.ndarray:
    """``start`` (a field of ``d.contact``: rows a contact's size apart, from the arena's start)
    over the whole contact buffer."""
    capacity = max(int(d.narena) // start.strides[0], 1)
    return np.lib.stride_tricks.as_strided(start, (capacity, *start.shape[1:]), start.strides, writeable=writeable)


def _contact_view(d: mujoco.MjData) -> np.ndarray:
    return _whole_buffer(d.contact.geom, d, False)  # (ncon, 2); its data is the arena's start


def _contact_rows(d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    c = d.contact
    return _whole_buffer(c.mu, d, True), _whole_buffer(c.friction, d, True)


#: Per MjData, :func:`contact_geoms`'s view, and the ``mu`` (capacity,) and ``friction``
#: (capacity, 5) of its whole contact buffer that :func:`combine` writes (views that do not keep
#: their MjData alive: they must not outlive it, and drop out with it).
_contact_views: Callable[[mujoco.MjData], np.ndarray] = PerObject(_contact_view)
_contact_fields: Callable[[mujoco.MjData], tuple[np.ndarray, np.ndarray]] = PerObject(_contact_rows)


def contact_geoms(d: mujoco.MjData) -> np.ndarray:
    """The geom pairs of ``d``'s whole contact buffer, (capacity, 2) int32, a view whose first
    ``d.ncon`` rows are ``d.contact.geom``: MuJoCo keeps the contacts at the start of the arena
    (``d->contact = d->arena`` for the life of the MjData), so one view serves every substep
    without building ``d.contact`` (a few microseconds each). Rows past ``d.ncon`` hold whatever
    the arena holds; read only the first ``d.ncon``.

    Args:
        d: the data.

    Returns:
        The view (kept per MjData).
    """
    return _contact_views(d)


def applies(model: mujoco.MjModel) -> bool:
    """Whether a step of ``model`` goes through :func:`combine`: the scene declares Bullet's rule
    (:func:`declared`, kept per compiled model), its cone is elliptic and its geoms' friction
    values differ (:func:`mixed`; both read now: ``sim.setEngineInt32Param`` and
    ``sim.setEngineFloatParam`` change them at run time).

    Args:
        model: the compiled scene.

    Returns:
        True or False; a malformed text counts as no rule (the scene's load reports it).
    """
    return _kept(model).rule and int(model.opt.cone) == _ELLIPTIC and mixed(model)


def new_shape(spec: mujoco.MjSpec, geom) -> None:
    """Give a geom of a shape made at run time (``sim.createPrimitiveShape``, ``createMeshShape``,
    ``importShape``, a heightfield) CoppeliaSim's default material when the scene has Bullet's
    rule: a sliding friction of :data:`DEFAULT_COEFFICIENT` squared, as the ``.ttt`` converter
    stores a coefficient; in another scene the geom keeps MuJoCo's default.

    Args:
        spec: the scene's MjSpec.
        geom: the new ``MjsGeom``.
    """
    for text in spec.texts:
        if text.name == TEXT:
            try:
                if _combine(text.data) == "product":
                    geom.friction[0] = DEFAULT_COEFFICIENT ** 2
            except ValueError:  # the scene's load refused such a text
                pass
            return


def mixed(model: mujoco.MjModel) -> bool:
    """Whether the model's collidable geoms (``contype`` or ``conaffinity`` set) have more than
    one sliding friction value (else MuJoCo's larger value is the product's square root of equal
    values: nothing to change).

    Args:
        model: the compiled scene.

    Returns:
        True when two collidable geoms differ in sliding friction.
    """
    kept = _kept(model)
    key = kept.sliding.tobytes() + kept.contype.tobytes() + kept.conaffinity.tobytes()
    if kept.mixed[0] == key:  # a step asks twice (its substeps, its forward)
        return kept.mixed[1]
    f = kept.sliding[(kept.contype | kept.conaffinity) != 0]
    answer = bool(f.size) and float(f.min()) != float(f.max())
    kept.mixed = (key, answer)  # one assignment: a thread reads it whole
    return answer


def combine(m: mujoco.MjModel, d: mujoco.MjData, answers: dict | None = None, sliding: np.ndarray | None = None) -> None:
    """Give the contacts ``mj_step1`` (or ``mj_fwdPosition``) made Bullet's combined friction
    (module docstring), all contacts at once. Which contacts change and their new friction depend
    only on the contacts' geoms and the frictions MuJoCo read: the answers are kept per set of
    contact geoms while the model and those frictions are the same (consecutive substeps mostly
    find the same contacts), so a substep costs a dictionary lookup and at most two writes. Once
    per position stage: a second call would scale ``mu`` again.

    Args:
        m: the model.
        d: its data, after the position stage and before the acceleration stage.
        answers: the kept answers for the frictions MuJoCo read (:func:`steps` reads them once
            for its substeps, for the frictions it lowered); None: those of the model's own.
        sliding: (ngeom,) the geoms' own sliding frictions while :func:`steps` has lowered some
            of the model's; None: the model's are their own.
    """
    ncon = d.ncon
    if not ncon:
        return
    g = contact_geoms(d)[:ncon]
    if answers is None:
        answers = _answers(m, _frictions(m))
    answer = entry(answers, g.tobytes(), lambda: _answer(m, g, _contact_fields(d)[1][:ncon], sliding), _KEPT_ANSWERS)
    if answer is _UNCHANGED:
        return
    mus, frictions = _contact_fields(d)
    whole, i, pair, ratio, wide = answer
    if whole:  # every contact written (those MuJoCo's rule decides keep its value): no index arrays
        mu = mus[:ncon]
        mu *= ratio  # the regularised cone's mu = friction[0] * sqrt(R1 / R0)
        frictions[:ncon, :2] = pair
    elif i.size:
        mus[i] *= ratio
        frictions[i, :2] = pair
    else:
        return
    if wide:  # torsion and rolling rows: R[j + 1] = R[1] * friction[0]^2 / friction[j]^2
        c = d.contact
        friction = c.friction
        dim, R, D, adr = c.dim[i], d.efc_R, d.efc_D, c.efc_address[i]
        for k in np.flatnonzero((dim > 3) & (adr >= 0)):
            row, fk = int(adr[k]), friction[i[k]]
            for j in range(2, int(dim[k]) - 1):
                R[row + j + 1] = R[row + 1] * fk[0] * fk[0] / max(fk[j] * fk[j], 1e-15)
                D[row + j + 1] = 1.0 / R[row + j + 1]


def _frictions(m: mujoco.MjModel) -> bytes:
    """What MuJoCo's friction of a contact depends on besides its geoms, as bytes: the geoms'
    sliding frictions, and the override of every contact's (``mjENBL_OVERRIDE``, ``o_friction``)."""
    opt = m.opt
    override = opt.o_friction.tobytes() if opt.enableflags & _OVERRIDE else b""
    return _kept(m).sliding.tobytes() + override


#: How many sets of contact geoms :func:`combine` keeps answers for, per frictions, and how many
#: frictions (a step's lowered ones among them) it keeps answers for, per model.
_KEPT_ANSWERS = 512
_KEPT_FRICTIONS = 16

#: :func:`_answer` for contacts that keep MuJoCo's values.
_UNCHANGED = (False, np.zeros(0, dtype=int), None, None, False)


def _answers(m: mujoco.MjModel, frictions: bytes) -> dict[bytes, tuple]:
    """:func:`combine`'s kept answers for ``m`` under ``frictions``."""
    return entry(_kept(m).answers, frictions, dict, _KEPT_FRICTIONS)  # type: ignore[no-any-return]


def _answer(m: mujoco.MjModel, g: np.ndarray, contact_friction: np.ndarray, sliding: np.ndarray | None) -> tuple:
    """:func:`combine`'s answer for contacts of geoms ``g`` (ncon, 2) whose friction MuJoCo set
    to ``contact_friction`` (ncon, 5), the geoms' own sliding frictions being ``sliding`` (None:
    the model's): (write every contact, the contacts to change, their sliding friction (n, 2:
    both tangents), its ratio to MuJoCo's, the model has a geom of condim > 3). In a model
    without MuJoCo's own rules (explicit pairs, flexes, priorities), MuJoCo gives two geoms the
    same value at every substep: the answer then covers every contact (ratio 1 and MuJoCo's
    value where Bullet's is the same), written with slices."""
    fg = (_kept(m).sliding if sliding is None else sliding).take(g)  # (ncon, 2); a flex's -1: left out below
    i, new, wide = _changed(m, g, fg)
    if sliding is not None:  # lowered frictions (steps): MuJoCo gave some contacts Bullet's value
        got = contact_friction[:, 0]  # already, and two geoms of one value may have met a lowered one
        wrong = got[i] != new
        own = np.maximum(fg[:, 0], mujoco.mjMINMU)  # MuJoCo's value of two geoms of one value
        equal = np.flatnonzero((fg[:, 0] == fg[:, 1]) & (got != own))
        i, new = np.concatenate([i[wrong], equal]), np.concatenate([new[wrong], own[equal]])
    if not i.size:
        return _UNCHANGED
    # MuJoCo's own value (the larger of the two, at least mjMINMU) follows from the same geoms
    ratio = new / contact_friction[i, 0]
    if _kept(m).special:
        return False, i, np.repeat(new[:, None], 2, axis=1), ratio, wide
    pair = contact_friction[:, :2].copy()
    pair[i] = new[:, None]
    whole = np.ones(len(g))
    whole[i] = ratio
    return True, i, pair, whole, wide


def _lowered(m: mujoco.MjModel, d: mujoco.MjData, frictions: bytes) -> tuple[np.ndarray, bytes] | None:
    """Sliding frictions for the model's geoms under which MuJoCo's own rule (the larger of two
    geoms' values) gives the contacts ``d`` has now Bullet's product: each geom that is the
    larger side of such a contact lowered to the contact's product (to the smallest of them
    where it has several), every other geom its own value; with the key of those frictions for
    :func:`combine` (``frictions``, :func:`_frictions` of ``m``, followed by the lowered
    values). Contacts that are all of one value each (a part rocking on another of its
    material between steps) keep the last lowered frictions: :func:`combine` checks every
    contact whatever they are. None when nothing was lowered, in a model with MuJoCo's own
    rules (explicit pairs, flexes, priorities), and under MuJoCo's override of every contact's
    friction. Kept per set of contact geoms while the model and its frictions are the same."""
    kept = _kept(m)
    if not d.ncon or kept.special or m.opt.enableflags & _OVERRIDE:
        return None
    answers, last = entry(kept.lowered, frictions, lambda: ({}, [None]), _KEPT_FRICTIONS)
    g = contact_geoms(d)[:d.ncon]
    answer = entry(answers, g.tobytes(), lambda: _lower(m, g, frictions), _KEPT_ANSWERS)
    if answer is None:
        return last[0]  # type: ignore[no-any-return]
    last[0] = answer
    return answer  # type: ignore[no-any-return]


def _lower(m: mujoco.MjModel, g: np.ndarray, frictions: bytes) -> tuple[np.ndarray, bytes] | None:
    """:func:`_lowered`'s frictions for contacts of geoms ``g`` (ncon, 2); None when no contact
    has two values."""
    sliding = _kept(m).sliding
    fg = sliding.take(g)
    i, new, _ = _changed(m, g, fg)
    if not i.size:
        return None
    larger = np.where(fg[i, 0] > fg[i, 1], g[i, 0], g[i, 1])
    low = np.full(len(sliding), np.inf)
    np.minimum.at(low, larger, new)
    lowered = low < sliding
    if not lowered.any():
        return None
    values = np.where(lowered, low, sliding)
    return values, frictions + values.tobytes()


def _changed(m: mujoco.MjModel, g: np.ndarray, fg: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(contacts to change, their combined friction, the model has wide contacts)`` for the
    contacts of geoms ``g`` (ncon, 2) whose sliding frictions are ``fg``."""
    kept = _kept(m)
    special, wide = kept.special, kept.wide
    i = np.flatnonzero(fg[:, 0] != fg[:, 1])
    if special and i.size:  # flex contacts, explicit <pair>s and priorities keep MuJoCo's rule
        i = _mujocos_own(m, g, i)
    pair = fg[i]
    # at least MuJoCo's own floor (mjMINMU, its mj_assignFriction): its elliptic cone scales the
    # normal by mu, and a mu of 0 (a frictionless slider on a floor) drops the contact's normal force
    new = np.sqrt(pair[:, 0] * pair[:, 1])
    np.clip(new, mujoco.mjMINMU, BULLET_MAX_FRICTION, out=new)
    return i, new, wide


def _mujocos_own(m: mujoco.MjModel, g: np.ndarray, i: np.ndarray) -> np.ndarray:
    """``i`` less the contacts MuJoCo's own rule decides: a flex's, an explicit ``<pair>``'s
    (its own friction) and those of two geoms of different ``priority``."""
    g1, g2 = g[i, 0], g[i, 1]
    keep = (g1 >= 0) & (g2 >= 0)
    keep &= m.geom_priority[np.maximum(g1, 0)] == m.geom_priority[np.maximum(g2, 0)]
    if m.npair:
        keys = np.minimum(g1, g2) * m.ngeom + np.maximum(g1, g2)
        pairs = np.minimum(m.pair_geom1, m.pair_geom2) * m.ngeom + np.maximum(m.pair_geom1, m.pair_geom2)
        keep &= ~np.isin(keys, pairs)
    return i[keep]


def steps(m: mujoco.MjModel, d: mujoco.MjData, n: int, each: Callable[[], None] | None = None) -> None:
    """``n`` MuJoCo steps with Bullet's combined friction: ``mj_step1``, :func:`combine`,
    ``mj_step2`` (``mj_step``'s two halves; a scene with moving surfaces steps through
    :func:`simx_server.sim.surfaces.substep` instead). For the substeps, the geoms on the larger
    side of the contacts found at the start get the contacts' product as their sliding friction
    (:func:`_lowered`), so that MuJoCo itself gives those contacts Bullet's value while they
    last and :func:`combine` corrects only the others; the model's own values are back when the
    steps end.

    Args:
        m: the model.
        d: its data, stepped.
        n: the number of steps.
        each: called after each step (:func:`simx_server.sim.physics.timed_step`'s clock, which
            may raise: the model's frictions are back before the exception leaves).
    """
    step1, step2 = mujoco.mj_step1, mujoco.mj_step2
    frictions = _frictions(m)  # nothing changes a friction between substeps
    lowered = _lowered(m, d, frictions)
    key, own, column = frictions, None, _kept(m).sliding
    if lowered is not None:
        values, key = lowered
        own = column.copy()
        column[:] = values
    answers = _answers(m, key)
    geoms = memoryview(contact_geoms(d))  # its slices' bytes are numpy's, for less work between the halves
    try:
        for _ in range(n):
            step1(m, d)
            ncon = d.ncon
            if ncon and answers.get(geoms[:ncon].tobytes()) is not _UNCHANGED:
                combine(m, d, answers, own)
            step2(m, d)
            if each is not None:
                each()
    finally:
        if own is not None:
            column[:] = own


def forward(m: mujoco.MjModel, d: mujoco.MjData) -> None:
    """``mj_forward`` with Bullet's combined friction: :func:`combine` after the position stage
    (which makes the contacts and their constraint rows), then the rest of ``mj_forward`` from
    the position stage's sensors on; the velocity stage reads none of what :func:`combine`
    writes (the rows' reference accelerations come from their stiffness and damping).

    Args:
        m: the model.
        d: its data.
    """
    mujoco.mj_fwdPosition(m, d)
    combine(m, d)
    mujoco.mj_sensorPos(m, d)
    if m.opt.enableflags & _ENERGY:
        mujoco.mj_energyPos(m, d)
    mujoco.mj_forwardSkip(m, d, _POSITION_STAGE, 0)

