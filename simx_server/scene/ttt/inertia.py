"""Shape inertias that MuJoCo refuses, repaired as V-REP would simulate them.

V-REP stores a shape's principal moments of inertia (``Ine``/``_ne``, or the 3x3 ``Imx`` of
CoppeliaSim 4.5 rev2: :mod:`simx_server.scene.ttt.shapes`) and simulates them as they are; MuJoCo
refuses moments that break the triangle inequality (``A + B >= C`` for each ordering: "inertia
must satisfy A + B >= C; use 'balanceinertia'"). Such moments become the nearest valid ones: the
excess ``C - A - B`` is moved in equal thirds off the largest moment onto the two others (the
Euclidean projection onto ``A + B = C``, which keeps their sum, the trace; with a margin of
MARGIN so that the MJCF's rounding keeps it valid), and each repaired shape is named in the load
report. MuJoCo's own ``balanceinertia`` (all three set to their mean) stays on in the written
MJCF as the compiler's last resort.

Small moments stay as the file has them: CoppeliaSim keeps any moment >= 0 (coppeliaSimLib
``CMeshWrapper::setPrincipalMomentsOfInertia``) and Bullet 2.78 is given the file's moments times
the mass (simExtDynamics ``CRigidBodyDyn_bullet278``: ``localInertia = im * mass``). Only what
MuJoCo refuses for a moving body (a moment at or below ``mjMINVAL``, 1e-15) is raised, to
FLOOR. (A floor of 1e-9 kg m2 once made a 0.5 mg, 1 cm cube 120 times too hard to turn: pushed,
it tumbled on like a flywheel where V-REP's stops within a millimetre.)
"""

from __future__ import annotations

import numpy as np

#: kg·m², the smallest moment a moving body gets: ten times MuJoCo's ``mjMINVAL`` (1e-15), which
#: it refuses, so that the MJCF's six significant digits keep it above.
FLOOR = 1e-14
#: Relative margin kept above ``A + B = C``: the MJCF keeps 6 significant digits, and moments on
#: the boundary (a flat plate's) must not break it once rounded.
MARGIN = 1e-4
_MAX_NAMED = 20  # shapes named in the report line; the count covers all


def repaired(conv, name: str, moments: np.ndarray) -> np.ndarray:
    """The principal moments (kg·m², 3) of shape ``name``, each at least FLOOR, made valid where
    they break ``A + B >= C``; records ``name`` in ``conv.repaired_inertias``."""
    m = np.maximum(np.asarray(moments, dtype=np.float64), FLOOR)
    if not np.all(np.isfinite(m)):
        return m
    big = int(np.argmax(m))
    others = m.sum() - m[big]
    if others >= m[big] * (1 + MARGIN):
        return m
    # (A + t) + (B + t) = (C - t)(1 + MARGIN): the excess off C, in thirds, onto A and B
    t = (m[big] * (1 + MARGIN) - others) / (3 + MARGIN)
    out = m + t
    out[big] = m[big] - t
    if others < m[big]:  # broken in the file (not only at the rounding's edge): said
        conv.repaired_inertias.append(name)
    return out


def report(conv) -> None:
    """One ``repaired`` line of the report naming the shapes whose inertias were repaired."""
    names = conv.repaired_inertias
    if names:
        shown = ", ".join(names[:_MAX_NAMED]) + (", ..." if len(names) > _MAX_NAMED else "")
        conv.report.repaired.append(f"{len(names)} x shape inertias that break A + B >= C, set to the nearest "
                                    f"valid ones: {shown}")
