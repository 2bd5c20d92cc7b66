"""The equality rows a motor's effective inertia reads (``mechanisms.equality_jacobian``): the
rows MuJoCo itself built, for sparse and dense Jacobians, with some equalities left out."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from simx_server.sim import mechanisms

_LINKS = "".join(
    f'<body name="b{i}" pos="{0.3 * i - 1.0} 0 0.12"><joint name="j{i}" axis="0 1 0"/>'
    f'<geom type="box" size=".1 .1 .1"/><body pos="0 0 .3"><joint type="slide"/><geom size=".05"/></body></body>'
    for i in range(10))
_SCENE = f"""<mujoco><option jacobian="{{jacobian}}"/><worldbody><geom type="plane" size="2 2 .1"/>{_LINKS}
</worldbody><equality><joint joint1="j0" joint2="j1" polycoef="0 1 0 0 0"/>
<joint joint1="j2" joint2="j3" polycoef="0.1 -1 0 0 0"/><weld body1="b4" body2="b5"/>
<connect body1="b6" body2="b7" anchor="0 0 0"/><joint joint1="j8"/></equality></mujoco>"""


def _all_rows(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    if mujoco.mj_isSparse(m):
        dense = np.zeros((d.nefc, m.nv))
        mujoco.mju_sparse2dense(dense, d.efc_J, d.efc_J_rownnz, d.efc_J_rowadr, d.efc_J_colind)
        return dense
    return d.efc_J[:d.nefc * m.nv].reshape(d.nefc, m.nv)


@pytest.mark.parametrize("jacobian", ["sparse", "dense"])
def test_the_rows_are_mujocos_own_for_the_equalities_held(jacobian):
    m = mujoco.MjModel.from_xml_string(_SCENE.format(jacobian=jacobian))
    d = mujoco.MjData(m)
    assert bool(mujoco.mj_isSparse(m)) == (jacobian == "sparse")
    rng = np.random.default_rng(3)
    seen = 0
    for trial in range(60):
        d.qpos[:] = rng.normal(0.0, 0.5, m.nq)
        d.eq_active[:] = rng.random(m.neq) < 0.7
        mujoco.mj_forward(m, d)
        ignore = None if trial % 3 == 0 else rng.choice(m.neq, size=int(rng.integers(0, m.neq + 1)), replace=False)
        held = d.eq_active.astype(bool)
        if ignore is not None:
            held[ignore] = False
        rows = [r for r in range(d.nefc) if d.efc_type[r] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
                and held[d.efc_id[r]]]
        J, R = mechanisms.equality_jacobian(m, d, ignore)
        assert J.shape == (len(rows), m.nv) and R.shape == (len(rows),)
        np.testing.assert_array_equal(J, _all_rows(m, d)[rows])
        np.testing.assert_array_equal(R, d.efc_R[rows])
        seen += len(rows)
    assert seen > 100  # the draws held rows of every kind often


def test_no_rows_when_every_active_equality_is_left_out():
    m = mujoco.MjModel.from_xml_string(_SCENE.format(jacobian="sparse"))
    d = mujoco.MjData(m)
    d.eq_active[:] = [1, 0, 1, 0, 0]
    mujoco.mj_forward(m, d)
    J, R = mechanisms.equality_jacobian(m, d, np.array([0, 2]))
    assert J.shape == (0, m.nv) and R.shape == (0,)
    J, _ = mechanisms.equality_jacobian(m, d, np.array([0]))
    assert J.shape == (6, m.nv)  # the weld's six rows
