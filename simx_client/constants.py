"""Every legacy remote API constant with its V-REP / CoppeliaSim value.

Values are those of ``vrepConst.py`` (V-REP 3.6) and ``simConst.py`` (CoppeliaSim 4.x),
which agree. Names are the legacy ones so that ``vrep.simx_opmode_blocking`` and
``sim.sim_scripttype_childscript`` resolve exactly as they did.
"""

from __future__ import annotations


# Operation modes (simx_opmode_*)
simx_opmode_oneshot = 0x000000
simx_opmode_blocking = 0x010000
simx_opmode_oneshot_wait = 0x010000
simx_opmode_continuous = 0x020000
simx_opmode_streaming = 0x020000
simx_opmode_oneshot_split = 0x030000
simx_opmode_continuous_split = 0x040000
simx_opmode_streaming_split = 0x040000
simx_opmode_discontinue = 0x050000
simx_opmode_buffer = 0x060000
simx_opmode_remove = 0x070000

# Return codes (bit flags, may be OR-ed)
simx_return_ok = 0x000000
simx_return_novalue_flag = 0x000001
simx_return_timeout_flag = 0x000002
simx_return_illegal_opmode_flag = 0x000004
simx_return_remote_error_flag = 0x000008
simx_return_split_progress_flag = 0x000010
simx_return_local_error_flag = 0x000020
simx_return_initialize_error_flag = 0x000040
simx_error_noerror = 0x000000
simx_error_novalue_flag = 0x000001
simx_error_timeout_flag = 0x000002
simx_error_illegal_opmode_flag = 0x000004
simx_error_remote_error_flag = 0x000008
simx_error_split_progress_flag = 0x000010
simx_error_local_error_flag = 0x000020
simx_error_initialize_error_flag = 0x000040

# Message header / command sub-header offsets
SIMX_VERSION = 0
SIMX_HEADER_SIZE = 18
simx_headeroffset_crc = 0
simx_headeroffset_version = 2
simx_headeroffset_message_id = 3
simx_headeroffset_client_time = 7
simx_headeroffset_server_time = 11
simx_headeroffset_scene_id = 15
simx_headeroffset_server_state = 17
SIMX_SUBHEADER_SIZE = 26
simx_cmdheaderoffset_mem_size = 0
simx_cmdheaderoffset_full_mem_size = 4
simx_cmdheaderoffset_pdata_offset0 = 8
simx_cmdheaderoffset_pdata_offset1 = 10
simx_cmdheaderoffset_cmd = 14
simx_cmdheaderoffset_delay_or_split = 18
simx_cmdheaderoffset_sim_time = 20
simx_cmdheaderoffset_status = 24
simx_cmdheaderoffset_reserved = 25

# Script types (options argument of simxCallScriptFunction)
sim_scripttype_mainscript = 0
sim_scripttype_childscript = 1
sim_scripttype_jointctrlcallback = 4
sim_scripttype_contactcallback = 5
sim_scripttype_customizationscript = 6
sim_scripttype_generalcallback = 7

# Object types (sim_object_*_type, used by simxGetObjects / simxGetObjectGroupData)
sim_object_shape_type = 0
sim_object_joint_type = 1
sim_object_graph_type = 2
sim_object_camera_type = 3
sim_object_dummy_type = 4
sim_object_proximitysensor_type = 5
sim_object_reserved1 = 6
sim_object_reserved2 = 7
sim_object_path_type = 8
sim_object_visionsensor_type = 9
sim_object_volume_type = 10
sim_object_mill_type = 11
sim_object_forcesensor_type = 12
sim_object_light_type = 13
sim_object_mirror_type = 14
sim_object_no_subtype = 200
sim_appobj_object_type = 109
sim_appobj_collision_type = 110
sim_appobj_distance_type = 111
sim_appobj_simulation_type = 112
sim_appobj_ik_type = 113
sim_appobj_constraintsolver_type = 114
sim_appobj_collection_type = 115
sim_appobj_ui_type = 116
sim_appobj_script_type = 117
sim_appobj_pathplanning_type = 118
sim_appobj_RESERVED_type = 119
sim_appobj_texture_type = 120

# Special handles (relativeToObjectHandle etc.)
sim_handle_all = -2
sim_handle_all_except_explicit = -3
sim_handle_self = -4
sim_handle_main_script = -5
sim_handle_tree = -6
sim_handle_chain = -7
sim_handle_single = -8
sim_handle_default = -9
sim_handle_all_except_self = -10
sim_handle_parent = -11

# Frequently used parameter ids
sim_intparam_program_version = 1
sim_intparam_mouse_x = 22
sim_intparam_mouse_y = 23
sim_intparam_mouse_buttons = 31
sim_intparam_current_page = 5
sim_floatparam_simulation_time_step = 1
sim_boolparam_waiting_for_trigger = 45
sim_boolparam_realtime_simulation = 25
sim_visionfloatparam_near_clipping = 1000
sim_visionfloatparam_far_clipping = 1001
sim_visionfloatparam_perspective_angle = 1004
sim_shapeintparam_static = 3003
sim_shapeintparam_respondable = 3004
sim_shapefloatparam_mass = 3005
sim_visionintparam_resolution_x = 1002
sim_visionintparam_resolution_y = 1003
sim_visionintparam_render_mode = 1017
# vision sensor render modes (sim_visionintparam_render_mode); simx renders opengl and colorcoded
sim_rendermode_opengl = 0
sim_rendermode_auxchannels = 1
sim_rendermode_colorcoded = 2
sim_rendermode_povray = 3
sim_rendermode_extrenderer = 5
sim_rendermode_extrendererwindowed = 6
sim_rendermode_opengl3 = 7
sim_rendermode_opengl3windowed = 8
sim_objfloatparam_abs_x_velocity = 11
sim_objfloatparam_abs_y_velocity = 12
sim_objfloatparam_abs_z_velocity = 13
sim_objfloatparam_abs_rot_velocity = 14
sim_jointfloatparam_velocity = 2012
sim_jointfloatparam_pid_p = 2002
sim_jointfloatparam_pid_i = 2003
sim_jointfloatparam_pid_d = 2004
sim_arrayparam_gravity = 0

# Other facts

# Mask separating the operation mode from its streaming delay / split size (v_repConst.h).
simx_cmdmask = 0x00ffff
