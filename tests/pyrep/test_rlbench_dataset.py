"""RLBench's dataset round trip on simx (issue 81): an episode saved by RLBench's own
``dataset_generator.save_demo`` (PNG images, depth as 24-bit RGB, colour-coded masks, the
low-dimensional observations pickled) reads back through ``rlbench.utils.get_stored_demos`` as
it was recorded (a reset and four steps of arm motion: the format of a live demo's steps, at a
fraction of a demo's time). RLBench is run, not copied: it is not on the package index, so without it (or
without the stand-in of its main scene, ``rlbench/task_design.ttt``, that
``../shared/rlbench/build_task_design.py`` writes) the test is skipped. The whole generator with
``--processes 2`` is ``benchmarks/rlbench_dataset.py``."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

rlbench = pytest.importorskip("rlbench")
if not (Path(rlbench.__file__).parent / "task_design.ttt").is_file():
    pytest.skip("RLBench's main scene (rlbench/task_design.ttt) is not there", allow_module_level=True)

CAMERAS = ("left_shoulder", "right_shoulder", "overhead", "wrist", "front")
LOW_DIM = ("joint_velocities", "joint_positions", "joint_forces", "gripper_open", "gripper_pose",
           "gripper_joint_positions", "gripper_touch_forces", "task_low_dim_state")


def _config():
    """The dataset generator's observation config (its ``run``), with small images."""
    from rlbench import ObservationConfig

    config = ObservationConfig()
    config.set_all(True)
    for name in CAMERAS:
        camera = getattr(config, f"{name}_camera")
        camera.image_size = [32, 32]
        camera.depth_in_meters = False
        camera.masks_as_one_channel = False
    return config


def test_a_saved_episode_reads_back_as_it_was_recorded(tmp_path):
    from rlbench.action_modes.action_mode import MoveArmThenGripper
    from rlbench.action_modes.arm_action_modes import JointVelocity
    from rlbench.action_modes.gripper_action_modes import Discrete
    from PIL import Image
    from rlbench.dataset_generator import save_demo
    from rlbench.demo import Demo
    from rlbench.environment import Environment
    from rlbench.tasks import ReachTarget
    from rlbench.utils import get_stored_demos

    config = _config()
    env = Environment(MoveArmThenGripper(JointVelocity(), Discrete()), obs_config=config, headless=True)
    env.launch()
    try:
        task = env.get_task(ReachTarget)
        _, first = task.reset()
        steps = [task.step(np.array([0.3, -0.2, 0.2, 0.3, 0.2, -0.3, 0.2, 1.0]))[0] for _ in range(4)]
        demo = Demo([first, *steps])
    finally:
        env.shutdown()
    recorded = copy.deepcopy(demo)
    save_demo(demo, str(tmp_path / "reach_target" / "variation0" / "episodes" / "episode0"))
    # masks read as files: get_stored_demos's rgb_handles_to_mask overflows uint8 on NumPy >= 2,
    # whatever the simulator (RLBench's own tests read no mask)
    paths, = get_stored_demos(1, True, str(tmp_path), 0, "reach_target", config, random_selection=False)
    for cam in CAMERAS:
        getattr(config, f"{cam}_camera").mask = False
    stored, = get_stored_demos(1, False, str(tmp_path), 0, "reach_target", config, random_selection=False)
    assert len(stored) == len(paths) == len(recorded) > 1
    for was, now, files in zip(recorded, stored, paths):
        for name in LOW_DIM:
            assert np.array_equal(np.asarray(getattr(was, name)), np.asarray(getattr(now, name))), name
        for cam in CAMERAS:
            rgb, depth = getattr(was, f"{cam}_rgb"), getattr(was, f"{cam}_depth")
            assert rgb.shape == (32, 32, 3) and rgb.max() > 0, cam
            assert np.array_equal(getattr(now, f"{cam}_rgb"), rgb), cam
            assert np.allclose(getattr(now, f"{cam}_depth"), depth, atol=1e-6), cam  # 24-bit fixed point
            assert np.allclose(getattr(now, f"{cam}_point_cloud"), getattr(was, f"{cam}_point_cloud"), atol=1e-4)
            coded = (getattr(was, f"{cam}_mask") * 255).astype(np.uint8)  # as save_demo writes it
            assert len(np.unique(coded.reshape(-1, 3), axis=0)) > 1, cam  # objects told apart
            assert np.array_equal(np.array(Image.open(getattr(files, f"{cam}_mask"))), coded), cam
