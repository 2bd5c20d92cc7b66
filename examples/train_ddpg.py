"""Train the tutorial's DDPG (stable-baselines3) on simx/UR5BallReach-v0, CPU only.

    pip install -e '.[train]'      # gymnasium, stable-baselines3, PyTorch, matplotlib
    nice -n 19 python examples/train_ddpg.py --servers 2 --steps 20000 --max-minutes 25 --out runs/ddpg

The script starts its own simx-servers (``ServerPool``, one per environment), trains DDPG on a
``SubprocVecEnv`` of ``--servers`` environments and writes to ``--out``:

* ``model.zip``: the policy kept (``stable_baselines3.DDPG.load``): the best of the deterministic
  evaluations run every ``--select-every`` steps on a server of its own (``best_model.zip``);
  ``model_final.zip`` is the policy at the end of training;
* ``episodes.csv``: one row per training episode: ``episode, env_steps, return, length,
  success, wall_s``;
* ``learning_curve.png``: episode returns and the success rate (rolling mean) against env steps;
* ``evaluation.json``: the trained (deterministic) policy and a random policy, each over
  ``--eval-episodes`` seeded episodes (seeds ``EVAL_SEED``, ``EVAL_SEED + 1``, ...): success
  rate, mean return and final distance; with the training's wall time, env steps and the machine.

What the agent sees and does (as the tutorial's DDPG): the tutorial's state, the ball centre's
pixel distance from the image centre and the depth there (``tutorial_state=True``: from the
eye-in-hand Kinect's colour-coded render instead of YOLO), with the signed pixel offset that
gives its direction and the three driven joints' angles; it acts with offsets of joints 1-3
(degrees, at most ``max_offset_deg`` a step). The reward is minus the gripper's distance to the
ball (m) each step; an episode ends on success (within 5 cm) or after ``--episode-steps``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import simx_client.envs  # noqa: F401  (registers simx/UR5BallReach-v0)

from simx_client.envs.wrappers import TutorialStateObservation

EVAL_SEED = 10_000  # evaluation episodes use seeds EVAL_SEED, EVAL_SEED + 1, ... (never seen in training)
SELECT_SEED = 5_000  # the model-selection evaluations' environment starts from this seed


def make_env(host: str, port: int, episode_steps: int) -> gym.Env:
    """UR5BallReach-v0 on the server at ``host:port``, 84x84 renders (the policy uses no image),
    the tutorial's state, actions rescaled to [-1, 1] (x ``max_offset_deg``)."""
    env = gym.make("simx/UR5BallReach-v0", host=host, port=port, width=84, height=84, joints=3,
                   tutorial_state=True, max_episode_steps=episode_steps)
    return gym.wrappers.RescaleAction(TutorialStateObservation(env), -1.0, 1.0)


def run_episodes(env: gym.Env, act, episodes: int, seed: int) -> dict:
    """``episodes`` episodes with seeds ``seed``, ``seed + 1``, ...; ``act(obs)`` -> action."""
    successes, returns, distances = [], [], []
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(act(obs))
            total += float(reward)
            done = terminated or truncated
        successes.append(bool(terminated))
        returns.append(total)
        distances.append(float(info["distance"]))
    return {"episodes": episodes, "success_rate": float(np.mean(successes)), "successes": int(np.sum(successes)),
            "mean_return": float(np.mean(returns)), "mean_final_distance_m": float(np.mean(distances))}


def plot(rows: list[dict], selections: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.array([r["env_steps"] for r in rows], dtype=float)
    returns = np.array([r["return"] for r in rows], dtype=float)
    success = np.array([r["success"] for r in rows], dtype=float)
    window = max(1, min(50, len(rows) // 5))
    kernel = np.ones(window) / window
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=100)
    ax.plot(steps, returns, ".", ms=3, alpha=0.35, color="tab:blue", label="episode return")
    if len(rows) >= window:
        ax.plot(steps[window - 1:], np.convolve(returns, kernel, "valid"), color="tab:blue",
                label=f"return, mean of {window}")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("return (sum of -distance, m)")
    ax2 = ax.twinx()
    if len(rows) >= window:
        ax2.plot(steps[window - 1:], np.convolve(success, kernel, "valid"), color="tab:green",
                 label=f"success rate, mean of {window}")
    picked = [s for s in selections if s["success_rate"] is not None]
    if picked:
        ax2.plot([s["env_steps"] for s in picked], [s["success_rate"] for s in picked], "o", color="tab:red",
                 ms=5, label="success rate, deterministic policy (selection evaluations)")
    ax2.set_ylim(0, 1.05)
    ax2.set_ylabel("success rate")
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], loc="lower right", fontsize=8)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--servers", type=int, default=2, help="simx-servers = environments (default 2)")
    parser.add_argument("--steps", type=int, default=20_000, help="environment steps to train (all envs)")
    parser.add_argument("--episode-steps", type=int, default=100, help="steps before an episode is truncated")
    parser.add_argument("--learning-starts", type=int, default=1_000, help="random steps before learning")
    parser.add_argument("--eval-episodes", type=int, default=50, help="seeded episodes per policy")
    parser.add_argument("--select-every", type=int, default=2_000,
                        help="env steps between evaluations that pick the model kept (best mean return)")
    parser.add_argument("--select-episodes", type=int, default=10, help="episodes of each such evaluation")
    parser.add_argument("--max-minutes", type=float, default=None,
                        help="stop training after this many minutes of wall time (then save and evaluate)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/ddpg", help="folder for the model, CSV, PNG and JSON")
    args = parser.parse_args(argv)

    import torch
    from stable_baselines3 import DDPG
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    from simx_server.pool import ServerPool

    torch.set_num_threads(1)  # small networks: one thread is fastest and leaves the cores to the servers
    set_random_seed(args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []

    log = open(out / "episodes.csv", "w", newline="")
    writer = csv.DictWriter(log, ["episode", "env_steps", "return", "length", "success", "wall_s"])
    writer.writeheader()

    class EpisodeLog(BaseCallback):
        """One row per finished training episode (VecMonitor's ``info["episode"]``), written as
        it ends (the CSV can be watched during the training)."""

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    rows.append({"episode": len(rows) + 1, "env_steps": self.num_timesteps,
                                 "return": round(float(info["episode"]["r"]), 4), "length": int(info["episode"]["l"]),
                                 "success": int(bool(info.get("is_success", False))),
                                 "wall_s": round(time.monotonic() - start, 1)})
                    writer.writerow(rows[-1])
                    log.flush()
            return args.max_minutes is None or time.monotonic() - start < 60 * args.max_minutes

    # One server more than environments: the model-selection evaluations run on it, beside training.
    with ServerPool(args.servers + 1, None, "--speed", "0") as pool:
        fns = [lambda a=a: make_env(*a, args.episode_steps) for a in pool.addresses[:-1]]
        # One process per environment (spawn: no forked Zenoh session); one environment: this process.
        venv = VecMonitor(SubprocVecEnv(fns, start_method="spawn") if len(fns) > 1 else DummyVecEnv(fns))
        venv.seed(args.seed)
        n_actions = venv.action_space.shape[0]
        model = DDPG("MlpPolicy", venv, learning_rate=1e-3, buffer_size=200_000,
                     learning_starts=args.learning_starts, batch_size=256, tau=0.005, gamma=0.98,
                     train_freq=1, gradient_steps=-1,
                     action_noise=NormalActionNoise(np.zeros(n_actions), 0.2 * np.ones(n_actions)),
                     policy_kwargs={"net_arch": [256, 256]}, seed=args.seed, device="cpu", verbose=0)
        # DDPG's policy can collapse late in training (the first full run did: docs/TRAINING.md), so the
        # model kept is the best of deterministic evaluations every --select-every steps (SB3's
        # EvalCallback; its episodes' seeds come from SELECT_SEED, apart from the final evaluation's).
        select_env = Monitor(make_env(*pool.addresses[-1], args.episode_steps))
        select_env.reset(seed=SELECT_SEED)
        select = EvalCallback(select_env, eval_freq=max(1, args.select_every // len(fns)),
                              n_eval_episodes=args.select_episodes, best_model_save_path=str(out),
                              log_path=str(out), deterministic=True, verbose=0)
        start = time.monotonic()
        model.learn(total_timesteps=args.steps, callback=CallbackList([EpisodeLog(), select]))
        train_s = time.monotonic() - start
        env_steps = model.num_timesteps
        venv.close()
        select_env.close()
        log.close()
        model.save(out / "model_final")
        best = out / "best_model.zip"
        kept = DDPG.load(best, device="cpu") if best.exists() else model
        kept.save(out / "model")
        selections = [{"env_steps": int(t), "mean_return": round(float(np.mean(r)), 3),
                       "success_rate": float(np.mean(sc)) if len(sc) else None}
                      for t, r, sc in zip(select.evaluations_timesteps, select.evaluations_results,
                                          select.evaluations_successes or [[]] * len(select.evaluations_results))]

        env = make_env(*pool.addresses[0], args.episode_steps)
        env.action_space.seed(args.seed)
        trained = run_episodes(env, lambda o: kept.predict(o, deterministic=True)[0], args.eval_episodes, EVAL_SEED)
        random_policy = run_episodes(env, lambda o: env.action_space.sample(), args.eval_episodes, EVAL_SEED)
        final = (run_episodes(env, lambda o: model.predict(o, deterministic=True)[0], min(10, args.eval_episodes),
                              EVAL_SEED) if kept is not model else trained)
        env.close()

    result = {
        "algorithm": "DDPG (stable-baselines3)", "env": "simx/UR5BallReach-v0", "servers": args.servers,
        "seed": args.seed, "episode_steps": args.episode_steps, "train_env_steps": int(env_steps),
        "train_wall_s": round(train_s, 1), "train_episodes": len(rows),
        "env_steps_per_s": round(env_steps / train_s, 1), "eval_seeds": [EVAL_SEED, EVAL_SEED + args.eval_episodes - 1],
        "trained": trained, "random": random_policy, "final_model_first_10_seeds": final,
        "kept_model": "best of the selection evaluations" if kept is not model else "the final model",
        "selection_evaluations": selections,
        "machine": f"{platform.node()}: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
                   f"torch {torch.__version__}",
    }
    (out / "evaluation.json").write_text(json.dumps(result, indent=2) + "\n")
    plot(rows, selections, out / "learning_curve.png",
         f"DDPG on simx/UR5BallReach-v0 (tutorial state, {args.servers} servers): evaluation "
         f"{trained['successes']}/{trained['episodes']} reached vs random {random_policy['successes']}/"
         f"{random_policy['episodes']}")
    print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
