"""V-REP 3.x's global names in child scripts, mapped onto the one ``sim`` API table.

V-REP before 3.6 wrote ``simGetObjectHandle(...)``, ``sim_handle_self`` and
``if (sim_call_type==sim_childscriptcall_initialization) then``; CoppeliaSim 4.x writes
``sim.getObjectHandle``, ``sim.handle_self`` and ``sysCall_init``. simx has ONE implementation
(the ``sim`` functions of :mod:`simx_server.api.sim`, registered in
:data:`simx_server.api.registry.SIM`) and this table of aliases:

* :func:`sim_name` gives the ``sim`` function a 3.x global name calls: the exceptions of
  :data:`FUNCTION_ALIASES` (the renames CoppeliaSim's loader applies, ``CDetachedScript::
  _performNewApiAdjustments_old`` and ``_adjustScriptText5/7_old``), otherwise V-REP's own rule
  ``simXxxYyy`` -> ``sim.xxxYyy``;
* :data:`CONSTANTS` are the 3.x constants the generated constant table lacks: the call types of
  ``sim_call_type`` (``sim_childscriptcall_*``, ``sim_customizationscriptcall_*``, as
  CoppeliaSim's ``sim.syscb_*`` values), script attributes, thread resume locations;
* :data:`V_REP_3_FUNCTIONS` is every 3.x global function (CoppeliaSim's table of them, V-REP's
  old custom UIs, the remote API plugin's); docs/SCRIPTS.md lists each with its status
  (:func:`status`), and ``tests/scripts/test_legacy_scripts.py`` keeps that list true.

Lua resolves a 3.x global through :data:`LEGACY_LUA` (run after :data:`~simx_server.scripts.lua_prelude.PRELUDE`):
a name ``sim`` lacks is a function that raises an error naming it when called.
"""

from __future__ import annotations

import re

__all__ = ["CONSTANTS", "FUNCTION_ALIASES", "LEGACY_LUA", "SYSCB", "UI_FUNCTIONS", "V_REP_3_FUNCTIONS",
           "sim_name", "status"]

#: CoppeliaSim's system-callback numbers (``sim.syscb_*``); ``sim_call_type`` takes these values.
SYSCB: dict[str, int] = {
    "init": 0, "cleanup": 1, "nonsimulation": 2, "beforesimulation": 3, "aftersimulation": 4,
    "actuation": 5, "sensing": 6, "suspended": 7, "suspend": 8, "resume": 9,
    "beforeinstanceswitch": 10, "afterinstanceswitch": 11, "beforecopy": 12, "aftercopy": 13,
    "jointcallback": 17, "contactcallback": 20, "dyncallback": 21, "threadmain": 31,
}

#: Life-cycle functions and the ``sim_call_type`` of each (old-style scripts run their whole
#: text with that value instead of calling the function).
CALL_TYPES: dict[str, int] = {
    "sysCall_init": SYSCB["init"], "sysCall_cleanup": SYSCB["cleanup"],
    "sysCall_nonSimulation": SYSCB["nonsimulation"], "sysCall_beforeSimulation": SYSCB["beforesimulation"],
    "sysCall_afterSimulation": SYSCB["aftersimulation"], "sysCall_actuation": SYSCB["actuation"],
    "sysCall_sensing": SYSCB["sensing"], "sysCall_suspended": SYSCB["suspended"],
    "sysCall_suspend": SYSCB["suspend"], "sysCall_resume": SYSCB["resume"],
}

_CALL_TYPE_NAMES = {
    "mainscriptcall_initialization": "init", "mainscriptcall_cleanup": "cleanup", "mainscriptcall_regular": "actuation",
    "childscriptcall_initialization": "init", "childscriptcall_cleanup": "cleanup",
    "childscriptcall_actuation": "actuation", "childscriptcall_sensing": "sensing",
    "customizationscriptcall_initialization": "init", "customizationscriptcall_cleanup": "cleanup",
    "customizationscriptcall_nonsimulation": "nonsimulation",
    "customizationscriptcall_lastbeforesimulation": "beforesimulation",
    "customizationscriptcall_firstaftersimulation": "aftersimulation",
    "customizationscriptcall_simulationactuation": "actuation",
    "customizationscriptcall_simulationsensing": "sensing",
    "customizationscriptcall_simulationpause": "suspended",
    "customizationscriptcall_simulationpausefirst": "suspend",
    "customizationscriptcall_simulationpauselast": "resume",
    "customizationscriptcall_lastbeforeinstanceswitch": "beforeinstanceswitch",
    "customizationscriptcall_firstafterinstanceswitch": "afterinstanceswitch",
    "customizationscriptcall_beforecopy": "beforecopy", "customizationscriptcall_aftercopy": "aftercopy",
}

#: ``sim.X`` constants of 3.x scripts (Lua: also ``sim_X``) that the generated table lacks.
CONSTANTS: dict[str, int] = {
    **{f"syscb_{k}": v for k, v in SYSCB.items()},
    **{k: SYSCB[v] for k, v in _CALL_TYPE_NAMES.items()},
    "childscriptcall_threaded": -1,  # CoppeliaSim maps it to -1: no call has that type
    # simSetScriptAttribute / simGetScriptAttribute (V-REP 3.x values)
    "customizationscriptattribute_activeduringsimulation": 0, "scriptattribute_executionorder": 1,
    "scriptattribute_executioncount": 2, "childscriptattribute_automaticcascadingcalls": 3,
    "childscriptattribute_enabled": 4, "scriptattribute_enabled": 4,
    "customizationscriptattribute_cleanupbeforesave": 5, "scriptattribute_debuglevel": 6,
    "scriptattribute_scripttype": 7, "scriptattribute_scripthandle": 8,
    # simSetThreadResumeLocation
    "scriptthreadresume_allnotyetresumed": -1, "scriptthreadresume_default": 0,
    "scriptthreadresume_actuation_first": 1, "scriptthreadresume_actuation_last": 2,
    "scriptthreadresume_sensing_first": 3, "scriptthreadresume_sensing_last": 4,
    "scriptthreadresume_custom": 5,
    "scriptexecorder_first": 0, "scriptexecorder_normal": 1, "scriptexecorder_last": 2,
}

#: 3.x global names whose ``sim`` function is not ``simXxx`` -> ``xxx``.
FUNCTION_ALIASES: dict[str, str] = {
    # _adjustScriptText7_old (V-REP <= 3.3.2 packing names)
    "simPackInts": "packInt32Table", "simPackUInts": "packUInt32Table", "simPackFloats": "packFloatTable",
    "simPackDoubles": "packDoubleTable", "simPackBytes": "packUInt8Table", "simPackWords": "packUInt16Table",
    "simUnpackInts": "unpackInt32Table", "simUnpackUInts": "unpackUInt32Table",
    "simUnpackFloats": "unpackFloatTable", "simUnpackDoubles": "unpackDoubleTable",
    "simUnpackBytes": "unpackUInt8Table", "simUnpackWords": "unpackUInt16Table",
    # _adjustScriptText5_old (V-REP < 3.3.0 parameter names)
    "simGetBooleanParameter": "getBoolParam", "simSetBooleanParameter": "setBoolParam",
    "simGetIntegerParameter": "getInt32Parameter", "simSetIntegerParameter": "setInt32Param",
    "simGetFloatingParameter": "getFloatParam", "simSetFloatingParameter": "setFloatParam",
    # V-REP 3.x's names of the parameter calls -> CoppeliaSim 4.2's (sim.getBoolParam...)
    **{f"sim{v}{k}Parameter": f"{v.lower()}{k}Param" for k in ("Bool", "Int32", "Float", "String", "Array",
                                                                 "EngineFloat", "EngineInt32", "EngineBool")
       for v in ("Get", "Set")},
    "simGetInt32Parameter": "getInt32Parameter",  # 3.x's answers where 4.x raises (api.sim.legacy)
    "simGetObjectIntParameter": "getObjectInt32Parameter", "simSetObjectIntParameter": "setObjectInt32Parameter",
    # _performNewApiAdjustments_old's renames
    "simBoolOr16": "boolOr32", "simBoolAnd16": "boolAnd32", "simBoolXor16": "boolXor32",
    "simGetRealTimeSimulation": "getRealTimeSimulation", "simGetGraphCurve": "getGraphCurveData",
    # the remote API plugin (simExtRemoteApi*: simRemoteApi.* in 4.x)
    "simExtRemoteApiStart": "remoteApiStart", "simExtRemoteApiStop": "remoteApiStop",
    "simExtRemoteApiStatus": "remoteApiStatus", "simExtRemoteApiReset": "remoteApiReset",
}

#: V-REP's old custom UIs (``simGetUIHandle``...: removed in V-REP 3.4; ``BBK`` blocks of old
#: scene files) -> the neutral value each returns on a headless server.
UI_FUNCTIONS: dict[str, object] = {
    "simGetUIHandle": -1, "simGetUIProperty": 0, "simGetUIEventButton": -1, "simSetUIProperty": 1,
    "simGetUIButtonSize": [0, 0], "simGetUIButtonProperty": 0, "simSetUIButtonProperty": 1,
    "simGetUISlider": 0, "simSetUISlider": 1, "simSetUIButtonLabel": 1, "simGetUIButtonLabel": "",
    "simCreateUIButtonArray": 1, "simSetUIButtonArrayColor": 1, "simDelUIButtonArray": 1,
    "simCreateUI": -1, "simCreateUIButton": -1, "simSaveUI": 1, "simLoadUI": [], "simRemoveUI": 1,
    "simGetUIPosition": [0, 0], "simSetUIPosition": 1, "simSetUIButtonColor": 1,
    "simSetUIButtonTexture": 1, "simSetUIButtonVisibility": 1, "simGetUIButtonVisibility": 1,
}

_API_MAP = """
simGetScriptName simGetObjectAssociatedWithScript simGetScriptAssociatedWithObject
simGetCustomizationScriptAssociatedWithObject simGetScriptExecutionCount
simIsScriptExecutionThreaded simIsScriptRunningInThread simOpenModule simCloseModule simHandleModule
simBoolOr32 simBoolAnd32 simBoolXor32 simHandleDynamics simHandleIkGroup simCheckIkGroup
simHandleCollision simReadCollision simHandleDistance simReadDistance simHandleProximitySensor
simReadProximitySensor simHandleMill simResetCollision simResetDistance simResetProximitySensor
simResetMill simCheckProximitySensor simCheckProximitySensorEx simCheckProximitySensorEx2
simGetNameSuffix simSetNameSuffix simGetObjectHandle simAddScript simAssociateScriptWithObject
simSetScriptText simGetScriptHandle simGetCollectionHandle simRemoveCollection simEmptyCollection
simGetObjectPosition simGetObjectOrientation simSetObjectPosition simSetObjectOrientation
simGetJointPosition simSetJointPosition simSetJointTargetPosition simGetJointTargetPosition
simSetJointForce simGetPathPosition simSetPathPosition simGetPathLength simSetJointTargetVelocity
simGetJointTargetVelocity simSetPathTargetNominalVelocity simGetObjectName simGetCollectionName
simRemoveObject simRemoveModel simGetSimulationTime simGetSimulationState simGetSystemTime
simGetSystemTimeInMs simCheckCollision simCheckCollisionEx simCheckDistance
simGetObjectConfiguration simSetObjectConfiguration simGetConfigurationTree simSetConfigurationTree
simHandleMechanism simGetSimulationTimeStep simGetSimulatorMessage simResetGraph simHandleGraph
simAddStatusbarMessage simGetLastError simGetObjects simRefreshDialogs simGetModuleName
simGetIkGroupHandle simRemoveScript simGetCollisionHandle simGetDistanceHandle simGetMechanismHandle
simGetScriptSimulationParameter simSetScriptSimulationParameter simDisplayDialog simGetDialogResult
simGetDialogInput simEndDialog simStopSimulation simPauseSimulation simStartSimulation
simGetObjectMatrix simSetObjectMatrix simGetJointMatrix simSetSphericalJointMatrix
simBuildIdentityMatrix simCopyMatrix simBuildMatrix simGetEulerAnglesFromMatrix simInvertMatrix
simMultiplyMatrices simInterpolateMatrices simMultiplyVector simGetObjectChild simGetObjectParent
simSetObjectParent simGetObjectType simGetJointType simSetBoolParameter simGetBoolParameter
simSetInt32Parameter simGetInt32Parameter simSetFloatParameter simGetFloatParameter
simSetStringParameter simGetStringParameter simSetArrayParameter simGetArrayParameter
simSetObjectName simSetCollectionName simGetJointInterval simSetJointInterval simLoadScene
simSaveScene simLoadModel simSaveModel simIsObjectInSelection simAddObjectToSelection
simRemoveObjectFromSelection simGetObjectSelection simGetRealTimeSimulation simSetNavigationMode
simGetNavigationMode simSetPage simGetPage simCopyPasteObjects simScaleObjects
simGetObjectUniqueIdentifier simSetThreadAutomaticSwitch simGetThreadAutomaticSwitch
simSetThreadSwitchTiming simSetThreadResumeLocation simResumeThreads simSwitchThread
simCreateIkGroup simRemoveIkGroup simCreateIkElement simCreateCollection simAddObjectToCollection
simSaveImage simLoadImage simGetScaledImage simTransformImage simGetQHull simGetDecimatedMesh
simExportIk simComputeJacobian simSendData simReceiveData simPackInt32Table simPackUInt32Table
simPackFloatTable simPackDoubleTable simPackUInt8Table simPackUInt16Table simUnpackInt32Table
simUnpackUInt32Table simUnpackFloatTable simUnpackDoubleTable simUnpackUInt8Table
simUnpackUInt16Table simPackTable simUnpackTable simTransformBuffer simCombineRgbImages
simGetVelocity simGetObjectVelocity simAddForceAndTorque simAddForce simSetExplicitHandling
simGetExplicitHandling simSetGraphUserData simAddDrawingObject simRemoveDrawingObject
simAddDrawingObjectItem simAddParticleObject simRemoveParticleObject simAddParticleObjectItem
simGetObjectSizeFactor simSetIntegerSignal simGetIntegerSignal simClearIntegerSignal
simSetFloatSignal simGetFloatSignal simClearFloatSignal simSetStringSignal simGetStringSignal
simClearStringSignal simGetSignalName simWaitForSignal simPersistentDataWrite simPersistentDataRead
simSetObjectProperty simGetObjectProperty simSetObjectSpecialProperty simGetObjectSpecialProperty
simSetModelProperty simGetModelProperty simMoveToPosition simMoveToObject simFollowPath
simMoveToJointPositions simWait simGetDataOnPath simGetPositionOnPath simGetOrientationOnPath
simGetClosestPositionOnPath simReadForceSensor simBreakForceSensor simGetLightParameters
simSetLightParameters simGetLinkDummy simSetLinkDummy simSetShapeColor simGetShapeColor
simResetDynamicObject simSetJointMode simGetJointMode simSerialOpen simSerialClose simSerialSend
simSerialRead simSerialCheck simGetContactInfo simSetThreadIsFree simTubeOpen simTubeClose
simTubeWrite simTubeRead simTubeStatus simAuxiliaryConsoleOpen simAuxiliaryConsoleClose
simAuxiliaryConsolePrint simAuxiliaryConsoleShow simImportShape simImportMesh simExportMesh
simCreateMeshShape simGetShapeMesh simCreatePureShape simCreateHeightfieldShape simAddBanner
simRemoveBanner simCreateJoint simCreateDummy simCreateProximitySensor simCreatePath
simCreateForceSensor simCreateVisionSensor simInsertPathCtrlPoints simCutPathCtrlPoints
simGetIkGroupMatrix simFloatingViewAdd simFloatingViewRemove simAdjustView simCameraFitToView
simAnnounceSceneContentChange simGetObjectInt32Parameter simSetObjectInt32Parameter
simGetObjectFloatParameter simSetObjectFloatParameter simGetObjectStringParameter
simSetObjectStringParameter simGetRotationAxis simRotateAroundAxis simLaunchExecutable
simGetJointForce simSetIkGroupProperties simSetIkElementProperties simIsHandleValid
simGetObjectQuaternion simSetObjectQuaternion simSetShapeMassAndInertia simGetShapeMassAndInertia
simGroupShapes simUngroupShape simAddGhost simModifyGhost simQuitSimulator simGetThreadId
simSetShapeMaterial simGetTextureId simReadTexture simWriteTexture simCreateTexture
simWriteCustomDataBlock simReadCustomDataBlock simReadCustomDataBlockTags simAddPointCloud
simModifyPointCloud simGetShapeGeomInfo simGetObjectsInTree simSetObjectSizeValues
simGetObjectSizeValues simScaleObject simSetShapeTexture simGetShapeTextureId
simGetCollectionObjects simHandleCustomizationScripts simSetScriptAttribute simGetScriptAttribute
simHandleChildScripts simLaunchThreadedChildScripts simReorientShapeBoundingBox
simHandleVisionSensor simReadVisionSensor simResetVisionSensor simGetVisionSensorResolution
simGetVisionSensorImage simSetVisionSensorImage simGetVisionSensorCharImage
simSetVisionSensorCharImage simGetVisionSensorDepthBuffer simCheckVisionSensor
simCheckVisionSensorEx simBuildMatrixQ simGetQuaternionFromMatrix simFileDialog simMsgBox
simLoadModule simUnloadModule simCallScriptFunction simGetConfigForTipPose simGenerateIkPath
simGetExtensionString simComputeMassAndInertia simSetScriptVariable simGetEngineFloatParameter
simGetEngineInt32Parameter simGetEngineBoolParameter simSetEngineFloatParameter
simSetEngineInt32Parameter simSetEngineBoolParameter simCreateOctree simCreatePointCloud
simSetPointCloudOptions simGetPointCloudOptions simInsertVoxelsIntoOctree simRemoveVoxelsFromOctree
simInsertPointsIntoPointCloud simRemovePointsFromPointCloud simIntersectPointsWithPointCloud
simGetOctreeVoxels simGetPointCloudPoints simInsertObjectIntoOctree simSubtractObjectFromOctree
simInsertObjectIntoPointCloud simSubtractObjectFromPointCloud simCheckOctreePointOccupancy
simOpenTextEditor simSetVisionSensorFilter simGetVisionSensorFilter simHandleSimulationStart
simHandleSensingStart simAuxFunc simSetReferencedHandles simGetReferencedHandles simGetGraphCurve
simTest simRMLPos simRMLVel simRMLStep simRMLRemove simRMLMoveToPosition simRMLMoveToJointPositions
simBoolOr16 simBoolAnd16 simBoolXor16 simPackInts simPackUInts simPackFloats simPackDoubles
simPackBytes simPackWords simUnpackInts simUnpackUInts simUnpackFloats simUnpackDoubles
simUnpackBytes simUnpackWords simSetBooleanParameter simGetBooleanParameter simSetIntegerParameter
simGetIntegerParameter simSetFloatingParameter simGetFloatingParameter simGetObjectIntParameter
simSetObjectIntParameter simDelegateChildScriptExecution
"""

#: Every V-REP 3.x global function of child and customization scripts.
V_REP_3_FUNCTIONS: tuple[str, ...] = tuple(dict.fromkeys(
    _API_MAP.split() + list(UI_FUNCTIONS) + list(FUNCTION_ALIASES)))


def sim_name(name: str) -> str | None:
    """The ``sim`` function 3.x global ``name`` calls (``simGetObjectHandle`` -> ``getObjectHandle``),
    None for a name that is not a 3.x function name."""
    if name in FUNCTION_ALIASES:
        return FUNCTION_ALIASES[name]
    m = re.fullmatch(r"sim([A-Z])(\w*)", name)
    return m.group(1).lower() + m.group(2) if m else None


def status(name: str, functions: frozenset[str] | set[str] | tuple[str, ...]) -> str:
    """What 3.x function ``name`` does in simx, given the names of the ``sim`` ``functions``:
    ``sim.X`` (it calls ``sim`` function X), ``UI no-op`` or ``missing`` (an error naming it)."""
    if name in UI_FUNCTIONS:
        return "UI no-op"
    target = sim_name(name)
    return f"sim.{target}" if target in functions else "missing"

#: Plugin namespaces of V-REP / CoppeliaSim that simx does not have: ``simROS`` & co. are nil, as
#: in a CoppeliaSim without that plugin (scripts test ``if simROS then``).
_PLUGINS = ("simSurfRec", "simQHull", "simAssimp", "simOpenMesh", "simSkeleton", "simCam", "simJoy",
            "simWii", "simK3", "simMTB", "simBubble", "simICP", "simSDF", "simLuaCmd", "simGeom", "simZMQ", "simWS",
            "simSubprocess", "simEigen", "simGLTF", "simOMPL", "simURDF", "simBWF", "simROS", "simROS2", "simRRS1")

#: Lua run in each script's state after the prelude (arguments: the ``sim`` table, the
#: :data:`FUNCTION_ALIASES` and :data:`UI_FUNCTIONS` tables, the log writer): resolves V-REP 3.x
#: global names (``sim_X`` constants, ``simX`` functions) through ``sim``, makes ``simUI``
#: and the old custom UI functions logged no-ops, ``simRemoteApi`` the remote API plugin's table,
#: and a 3.x function simx lacks a function raising an error that names it.
LEGACY_LUA = r"""
local sim, aliases, ui_values, write_log = ...
local G = _G
local rawget, rawset, type, error, setmetatable, unpack = rawget, rawset, type, error, setmetatable, table.unpack
local plugins = {}
for _, name in ipairs({PLUGINS}) do plugins[name] = true end
local noted = {}
local function note(name)
  if not noted[name] then
    noted[name] = true
    write_log(name .. ": a user-interface call, a no-op on a headless server (docs/SCRIPTS.md)")
  end
end
local function copy(v) if type(v) == "table" then return {unpack(v)} end return v end
local uis, missing = {}, {}
for name, value in pairs(ui_values) do uis[name] = function() note(name) return copy(value) end end
local function absent(name)
  local f = missing[name]
  if not f then
    f = function() error(name .. " is not available in simx (docs/SCRIPTS.md lists the V-REP 3.x functions)", 2) end
    missing[name] = f
  end
  return f
end
-- simUI (4.x) / simExtCustomUI_* (3.x): every function a logged no-op with a neutral result;
-- its enumerations (simUI.curve_type.time ...) are 0.
local zeros = setmetatable({}, {__index = function() return 0 end})
local function ui_neutral(key)
  if key == "create" then return -1 end
  if key:match("^get.*Text$") or key == "getTitle" or key == "getEditValue" then return "" end
  if key:match("^is") then return false end
  if key:match("^get") then return 0 end
  return nil
end
G.simUI = setmetatable({}, {__index = function(t, key)
  if type(key) ~= "string" then return nil end
  if key:find("_") then rawset(t, key, zeros) return zeros end
  local value, name = ui_neutral(key), "simUI." .. key
  local f = function() note(name) return value end
  rawset(t, key, f)
  return f
end})
-- 4.5+ scripts' simUI = require('simUI'): the same headless table; a plugin simx lacks fails to
-- load with a message that says so (as in a CoppeliaSim without that plugin).
package.loaded.simUI = G.simUI
for name in pairs(plugins) do
  package.preload[name] = function()
    error(name .. " is a CoppeliaSim plugin that simx does not have (docs/SCRIPTS.md)", 0)
  end
end
G.simRemoteApi = {
  start = function(...) return sim.remoteApiStart(...) end,
  stop = function(...) return sim.remoteApiStop(...) end,
  status = function(...) return sim.remoteApiStatus(...) end,
  reset = function(...) return sim.remoteApiReset(...) end,
}
setmetatable(G, {__index = function(_, key)
  if type(key) ~= "string" then return nil end
  local c = key:match("^sim_(.+)$")
  if c then return rawget(sim, c) end
  if uis[key] then return uis[key] end
  local a = aliases[key]
  if a then return rawget(sim, a) or absent(key) end
  local x = key:match("^simExtCustomUI_(.+)$")
  if x then return G.simUI[x] end
  if plugins[key] or key:match("^sim%u+%d*$") then return nil end
  local f = key:match("^sim(%u.*)$")
  if f then return rawget(sim, f:sub(1, 1):lower() .. f:sub(2)) or absent(key) end
  return nil
end})
""".replace("{PLUGINS}", "{" + ", ".join(f'"{p}"' for p in _PLUGINS) + "}")


#: Markers around the generated list in docs/SCRIPTS.md.
DOC_BEGIN = "<!-- v-rep-3-functions: generated by legacy_names.doc_table -->"
DOC_END = "<!-- end of v-rep-3-functions -->"


def doc_table(functions: frozenset[str] | set[str] | tuple[str, ...]) -> str:
    """The Markdown list of every 3.x function and its status, as docs/SCRIPTS.md holds it
    (``python -m simx_server.scripts.threads`` prints it)."""
    rows = {"runs": [], "UI no-op": [], "missing": []}
    for name in sorted(V_REP_3_FUNCTIONS, key=str.lower):
        st = status(name, functions)
        if st.startswith("sim."):
            rows["runs"].append(f"`{name}` → `{st}`")
        else:
            rows[st].append(f"`{name}`")
    total = len(V_REP_3_FUNCTIONS)
    return "\n".join([
        DOC_BEGIN,
        f"**Run** ({len(rows['runs'])} of {total}; each calls the `sim` function named): "
        + ", ".join(rows["runs"]) + ".",
        "",
        f"**User-interface no-ops** ({len(rows['UI no-op'])}; logged once, neutral result): "
        + ", ".join(rows["UI no-op"]) + ".",
        "",
        f"**Missing** ({len(rows['missing'])}; calling one raises `NAME is not available in simx`): "
        + ", ".join(rows["missing"]) + ".",
        DOC_END,
    ])

