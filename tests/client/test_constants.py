"""Constants keep their legacy values (vrepConst.py / simConst.py), every one of them.

The table :mod:`simx_client.legacy_constants` is generated from the original files by
scripts/gen_constants.py; these tests check the legacy modules against it name by name and
value by value, the table against the reference notes, the generator's parser on small inputs,
and, on a real server, that ids simx does not implement answer a remote error naming them.
"""

import importlib.util
import re

import pytest

import sim
import simConst
import simx_client
import vrep
import vrepConst
from conftest import REFERENCE, ROOT, require_shared
from simx_client import constants as C
from simx_client import legacy_constants as T

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
    # names programs used that simx lacked before the generated table (issue 19)
    "sim_jointintparam_motor_enabled": 2000, "sim_jointintparam_ctrl_enabled": 2001,
    "sim_jointfloatparam_upper_limit": 2017, "sim_objintparam_visibility_layer": 10,
    "sim_boolparam_display_enabled": 16, "sim_stringparam_application_path": 0,
    "sim_api_errormessage_output": 2, "sim_message_eventcallback_scenesave": 0x104,
    "sim_intparam_platform": 19, "sim_drawing_cyclic": 0x1000, "sim_navigation_camerafly": 6,
    # values that are expressions in the files
    "sim_objectspecialproperty_detectable_all": 0x1F0, "sim_simulation_advancing_running": 0x11,
    "sim_simulation_advancing_lastbeforestop": 0x16,
}

# Counts of the original files (scripts/gen_constants.py prints them into the table's docstring).
VREPCONST_NAMES = 626  # 623 sim_* / simx_* and 3 SIMX_*
SIMCONST_NAMES = 626


@pytest.mark.parametrize("name,value", sorted(PINNED.items()))
def test_pinned_values(name, value):
    for module in (C, vrepConst, simConst, vrep, sim, simx_client):
        assert getattr(module, name) == value, module.__name__


def test_the_table_has_every_constant_of_both_files():
    assert len(T.VREPCONST) == VREPCONST_NAMES and len(T.SIMCONST) == SIMCONST_NAMES
    assert sum(n.startswith(("sim_", "simx_")) for n in T.VREPCONST) == 623
    assert sorted(n for n in T.VREPCONST if n.startswith("SIMX_")) == \
        ["SIMX_HEADER_SIZE", "SIMX_SUBHEADER_SIZE", "SIMX_VERSION"]
    assert all(type(v) is int for table in (T.VREPCONST, T.SIMCONST, T.V_REPCONST_H) for v in table.values())
    # V-REP 3.6.2's file and CoppeliaSim's name the same constants with the same values
    assert T.VREPCONST == T.SIMCONST
    # the header's families, whole
    assert sorted(n for n in T.V_REPCONST_H if n.startswith("sim_colorcomponent_")) == [
        "sim_colorcomponent_ambient", "sim_colorcomponent_ambient_diffuse", "sim_colorcomponent_auxiliary",
        "sim_colorcomponent_diffuse", "sim_colorcomponent_emission", "sim_colorcomponent_specular",
        "sim_colorcomponent_transparency"]
    assert [T.V_REPCONST_H[f"sim_rendermode_{m}"] for m in ("opengl", "colorcoded", "opengl3windowed")] == [0, 2, 8]


@pytest.mark.parametrize("modules,table", [((vrepConst, vrep, simx_client), C.VREP_CONSTANTS),
                                           ((simConst, sim), C.SIM_CONSTANTS)],
                         ids=["vrep", "sim"])
def test_each_module_exports_its_file_name_by_name_and_value_by_value(modules, table):
    file_table = T.VREPCONST if table is C.VREP_CONSTANTS else T.SIMCONST
    assert table == {**file_table, **C.ADDED_BY_SIMX}
    for module in modules:
        wrong = {n: getattr(module, n, "missing") for n, v in table.items() if getattr(module, n, None) != v}
        assert not wrong, f"{module.__name__}: {wrong}"
        names = set(module.__all__)
        constants = {n for n in names if not (n.startswith("simx") and callable(getattr(module, n)))}
        assert constants == set(table), module.__name__
        assert module.__all__ == sorted(module.__all__)
    assert set(modules[0].__all__) == set(table)  # vrepConst / simConst: constants only


def test_simx_adds_only_render_modes_and_the_command_mask():
    assert set(C.ADDED_BY_SIMX) == {n for n in T.V_REPCONST_H if n.startswith("sim_rendermode_")} | {"simx_cmdmask"}
    assert not set(C.ADDED_BY_SIMX) & set(T.VREPCONST)
    assert not hasattr(vrep, "sim_colorcomponent_ambient_diffuse")  # a script-only (Lua API) constant


def test_every_constant_of_the_reference():
    path = require_shared(REFERENCE / "constants.txt")
    pattern = re.compile(r"^\s*((?:simx_|sim_|SIMX_)\w+)\s*=\s*(-?(?:0x[0-9a-fA-F]+|\d+))", re.M)
    found = pattern.findall(path.read_text())
    assert len(found) > 100
    for name, value in found:
        assert getattr(C, name) == int(value, 0), name
        assert T.VREPCONST.get(name, C.ADDED_BY_SIMX.get(name)) == int(value, 0), name


def test_parameter_names_for_messages():
    assert C.names_of(16, "sim_boolparam_") == ["sim_boolparam_display_enabled"]
    assert C.describe(16, C.GLOBAL_PARAM_PREFIXES["boolean"]) == "sim_boolparam_display_enabled (16)"
    assert C.describe(2017, C.OBJECT_PARAM_PREFIXES) == "sim_jointfloatparam_upper_limit (2017)"
    assert C.describe(99, "sim_boolparam_") == "99"
    assert C.names_of(0x10, "sim_simulation_") == ["sim_simulation_advancing", "sim_simulation_advancing_firstafterstop"]


# ------------------------------------------------------------------ the generator
def _generator():
    spec = importlib.util.spec_from_file_location("gen_constants", ROOT / "scripts" / "gen_constants.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generator_evaluates_expressions_of_earlier_names():
    g = _generator()
    text = '"""doc"""\na = 0x10\nb = a|0x01  # comment\nc = -2\nd = ~0 & 0xff\ne = a + b << 1\n'
    assert g.python_constants(text, "t.py") == {"a": 16, "b": 17, "c": -2, "d": 255, "e": 66}
    for bad in ("a = b\n", "a = 'x'\n", "import os\n", "a = 1\na = 2\n", "a = f(1)\n", "a.b = 1\n"):
        with pytest.raises(g.SourceError):
            g.python_constants(bad, "t.py")


def test_generator_reads_c_enums_with_implicit_values():
    g = _generator()
    header = """
    #define NOT_AN_ENUM 3
    enum { /* colours */ sim_colorcomponent_ambient=0, sim_colorcomponent_ambient_diffuse=0,
           sim_colorcomponent_diffuse, // one
           sim_colorcomponent_specular };
    enum { sim_handleflag_greyscale = 0x00400000, sim_handleflag_model = sim_handleflag_greyscale|0x1,
           sim_rendermode_opengl = 0, sim_rendermode_auxchannels, simx_cmdmask = 0x00ffffu, other = f(2), after };
    """
    values = g.header_enum_constants(header)
    assert values["sim_colorcomponent_diffuse"] == 1 and values["sim_colorcomponent_specular"] == 2
    assert values["sim_handleflag_model"] == 0x400001 and values["simx_cmdmask"] == 0xFFFF
    assert values["other"] is None and values["after"] is None and "NOT_AN_ENUM" not in values
    assert g.header_families(header) == {
        "sim_colorcomponent_ambient": 0, "sim_colorcomponent_ambient_diffuse": 0, "sim_colorcomponent_diffuse": 1,
        "sim_colorcomponent_specular": 2, "sim_handleflag_greyscale": 0x400000, "sim_rendermode_opengl": 0,
        "sim_rendermode_auxchannels": 1, "simx_cmdmask": 0xFFFF}
    with pytest.raises(g.SourceError, match="sim_rendermode_"):
        g.header_families("enum { sim_colorcomponent_ambient=0 };")


def test_generator_refuses_a_file_other_than_its_source(tmp_path):
    g = _generator()
    files = [tmp_path / name for name in ("vrepConst.py", "simConst.py", "v_repConst.h")]
    files[0].write_text("sim_a = 1\n")
    files[1].write_text("sim_a = 1\n")
    files[2].write_text("enum { sim_rendermode_opengl=0, sim_colorcomponent_ambient=0, "
                        "sim_handleflag_greyscale=4, simx_cmdmask=0xffff };\n")
    assert g.main([str(f) for f in files]) == 2  # not the blobs recorded in SOURCES
    out = tmp_path / "table.py"
    assert g.main([*map(str, files), "--any-version", "-o", str(out)]) == 0
    namespace: dict = {}
    exec(out.read_text(), namespace)
    assert namespace["VREPCONST"] == {"sim_a": 1} and namespace["V_REPCONST_H"]["simx_cmdmask"] == 0xFFFF
    assert g.main([*map(str, files), "--any-version", "-o", str(out), "--check"]) == 0
    out.write_text(out.read_text() + "# edited\n")
    assert g.main([*map(str, files), "--any-version", "-o", str(out), "--check"]) == 1


def test_the_table_names_its_sources():
    doc = T.__doc__
    g = _generator()
    for source in g.SOURCES.values():
        assert source["repo"] in doc and source["commit"] in doc and source["blob"] in doc
    assert f"{VREPCONST_NAMES} names in vrepConst.py, {SIMCONST_NAMES} in simConst.py" in doc


# ------------------------------------------------------------------ on a real server
B = vrep.simx_opmode_blocking


def test_ids_simx_does_not_implement_answer_an_error_naming_them(vrep_client):
    """Newly named ids that have no meaning in simx answer remote error (8) and the legacy
    defaults, never made-up data; simxGetLastErrors names each by its legacy name."""
    cid = vrep_client
    rc, joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
    assert rc == 0
    vrep.simxGetLastErrors(cid, B)  # start from a clean list
    calls = [
        (vrep.simxGetBooleanParameter(cid, vrep.sim_boolparam_mirrors_enabled, B), (8, False),
         "sim_boolparam_mirrors_enabled (22)"),
        (vrep.simxSetBooleanParameter(cid, vrep.sim_boolparam_fog_enabled, True, B), 8,
         "sim_boolparam_fog_enabled (19)"),
        (vrep.simxGetIntegerParameter(cid, vrep.sim_intparam_visible_layers, B), (8, 0),
         "sim_intparam_visible_layers (11)"),
        (vrep.simxGetFloatingParameter(cid, vrep.sim_floatparam_stereo_distance, B), (8, 0.0),
         "sim_floatparam_stereo_distance (2)"),
        (vrep.simxGetStringParameter(cid, vrep.sim_stringparam_video_filename, B), (8, ""),
         "sim_stringparam_video_filename (1)"),
        (vrep.simxGetArrayParameter(cid, vrep.sim_arrayparam_fog_color, B), (8, [0.0, 0.0, 0.0]),
         "sim_arrayparam_fog_color (2)"),
        (vrep.simxSetIntegerParameter(cid, vrep.sim_intparam_platform, 0, B), 8,
         "sim_intparam_platform (19) is read-only"),
        (vrep.simxGetObjectIntParameter(cid, joint, vrep.sim_objintparam_visibility_layer, B), (8, 0),
         "sim_objintparam_visibility_layer (10)"),
        (vrep.simxGetObjectFloatParameter(cid, joint, vrep.sim_jointfloatparam_vortex_dep_multiplication, B), (8, 0.0),
         "sim_jointfloatparam_vortex_dep_multiplication (2032)"),
    ]
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert rc == 0 and len(errors) == len(calls), errors
    for (answer, expected, name), error in zip(calls, errors):
        assert answer == expected, name
        assert name in error, (name, error)
    # an id simx answers truthfully: a headless server has no display
    assert vrep.simxGetBooleanParameter(cid, vrep.sim_boolparam_display_enabled, B) == (0, False)
    assert vrep.simxGetBooleanParameter(cid, vrep.sim_boolparam_headless, B) == (0, True)
