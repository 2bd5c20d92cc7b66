"""Constants keep their legacy values (vrepConst.py / simConst.py)."""

import re

import pytest

import simConst
import vrepConst
from conftest import REFERENCE, require_shared
from simx_client import constants as C

PINNED = {
    "simx_opmode_oneshot": 0x000000, "simx_opmode_blocking": 0x010000, "simx_opmode_oneshot_wait": 0x010000,
    "simx_opmode_streaming": 0x020000, "simx_opmode_continuous": 0x020000, "simx_opmode_oneshot_split": 0x030000,
    "simx_opmode_streaming_split": 0x040000, "simx_opmode_discontinue": 0x050000, "simx_opmode_buffer": 0x060000,
    "simx_opmode_remove": 0x070000, "simx_return_ok": 0, "simx_return_novalue_flag": 1,
    "simx_return_timeout_flag": 2, "simx_return_illegal_opmode_flag": 4, "simx_return_remote_error_flag": 8,
    "simx_return_split_progress_flag": 16, "simx_return_local_error_flag": 32,
    "simx_return_initialize_error_flag": 64, "sim_scripttype_mainscript": 0, "sim_scripttype_childscript": 1,
    "sim_scripttype_customizationscript": 6, "sim_object_shape_type": 0, "sim_object_joint_type": 1,
    "sim_object_dummy_type": 4, "sim_object_proximitysensor_type": 5, "sim_object_visionsensor_type": 9,
    "sim_object_forcesensor_type": 12, "sim_object_light_type": 13, "sim_handle_all": -2, "sim_handle_self": -4,
    "sim_handle_parent": -11, "sim_visionfloatparam_near_clipping": 1000, "sim_visionfloatparam_far_clipping": 1001,
    "sim_visionintparam_resolution_x": 1002, "sim_visionintparam_resolution_y": 1003,
    "sim_visionfloatparam_perspective_angle": 1004, "sim_boolparam_realtime_simulation": 25,
    "sim_floatparam_simulation_time_step": 1, "simx_headeroffset_server_state": 17, "simx_cmdmask": 0xFFFF,
}


@pytest.mark.parametrize("name,value", sorted(PINNED.items()))
def test_pinned_values(name, value):
    assert getattr(C, name) == value
    assert getattr(vrepConst, name) == value
    assert getattr(simConst, name) == value


def test_every_constant_of_the_reference():
    path = require_shared(REFERENCE / "constants.txt")
    pattern = re.compile(r"^\s*((?:simx_|sim_|SIMX_)\w+)\s*=\s*(-?(?:0x[0-9a-fA-F]+|\d+))", re.M)
    found = pattern.findall(path.read_text())
    assert len(found) > 100
    for name, value in found:
        assert getattr(C, name) == int(value, 0), name
