"""Train the tutorial's DDPG (stable-baselines3) on simx/UR5BallReach-v0, CPU only.

    scripts/install-train.sh                 # gymnasium, stable-baselines3, PyTorch's CPU build, matplotlib
    python examples/train_ddpg.py --evaluate # the shipped policy against a random one (at most 2 minutes)
    python examples/train_ddpg.py --quick    # a short training whose success rate rises (3-7 minutes)
    nice -n 19 python examples/train_ddpg.py --servers 2 --steps 20000 --max-minutes 25 --out runs/ddpg

The script starts its own simx-servers (``ServerPool``), trains DDPG on a ``SubprocVecEnv`` of
``--servers`` environments and prints a progress line every ``--log-every`` env steps (steps/s,
the recent episodes' return and success rate, time left). ``--max-minutes`` bounds the whole
run: training stops early enough for the evaluations, which stop at the bound too (the JSON
then says how many episodes each policy had). It writes to ``--out``:

* ``model.zip``: the policy kept (``stable_baselines3.DDPG.load``): the best of the deterministic
  evaluations run every ``--select-every`` steps on a server of its own (``best_model.zip``);
  ``model_final.zip`` is the policy at the end of training; ``policy.zip``: the kept model's
  policy alone (``stable_baselines3.td3.policies.TD3Policy.load``, what ``--evaluate`` reads);
* ``episodes.csv``: one row per training episode: ``episode, env_steps, return, length,
  success, wall_s``;
* ``learning_curve.png``: episode returns and the success rate (rolling mean) against env steps;
* ``evaluation.json``: the trained (deterministic) policy and a random policy, each over
  ``--eval-episodes`` seeded episodes (seeds ``EVAL_SEED``, ``EVAL_SEED + 1``, ...): success
  rate, mean return and final distance; with the training's wall time, env steps and the machine.

``--evaluate [POLICY]`` trains nothing: it runs the policy (default: the one shipped in
docs/training/, trained by this script), then a random policy, over the same seeded episodes,
on ``--servers`` servers in parallel, for at most 2 minutes unless ``--max-minutes`` says
otherwise (the random policy's episodes, 100 steps each, then cover the seeds the time leaves),
and prints a JSON of the same figures.

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
import multiprocessing
import os
import platform
import sys
import time
import zipfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import gymnasium as gym
import numpy as np

import simx_client.envs  # noqa: F401  (registers simx/UR5BallReach-v0)

from simx_client.envs.wrappers import TutorialStateObservation

EVAL_SEED = 10_000  # evaluation episodes use seeds EVAL_SEED, EVAL_SEED + 1, ... (never seen in training)
SELECT_SEED = 5_000  # the model-selection evaluations' environment starts from this seed
#: the policy trained by this script and shipped with the docs (docs/TRAINING.md says how)
SHIPPED_POLICY = Path(__file__).resolve().parent.parent / "docs" / "training" / "ddpg_policy.zip"
EVALUATE_MINUTES = 2.0  # --evaluate's bound when --max-minutes is not given
#: --quick: a short run whose success rate rises within 3-7 minutes on 2 cores (the full
#: run's first 4,000 steps, with more frequent, shorter selection evaluations). No time bound:
#: a run cut by --max-minutes stops where the machine's speed says, so its result would vary;
#: without one, every run gives the same episodes and the same result (docs/TRAINING.md).
QUICK = {"steps": 4_000, "select_every": 1_000, "select_episodes": 5,
         "eval_episodes": 10, "log_every": 250, "out": "runs/ddpg-quick"}


def make_env(host: str, port: int, episode_steps: int) -> gym.Env:
    """UR5BallReach-v0 on the server at ``host:port``, 84x84 renders (the policy uses no image),
    the tutorial's state, actions rescaled to [-1, 1] (x ``max_offset_deg``)."""
    env = gym.make("simx/UR5BallReach-v0", host=host, port=port, width=84, height=84, joints=3,
                   tutorial_state=True, max_episode_steps=episode_steps)
    # float32 bounds, as the action space's dtype: float64 ones would be cast down, with a warning
    return gym.wrappers.RescaleAction(TutorialStateObservation(env), np.float32(-1.0), np.float32(1.0))


def load_policy(path: str | os.PathLike):
    """A deterministic ``obs -> action`` function from ``path``: a whole SB3 model
    (``model.zip``, ``DDPG.load``) or a policy alone (``policy.zip``, ``TD3Policy.load``)."""
    import torch
    from stable_baselines3 import DDPG
    from stable_baselines3.td3.policies import TD3Policy

    torch.set_num_threads(1)
    with zipfile.ZipFile(path) as z:
        whole_model = "data" in z.namelist()
    policy = DDPG.load(path, device="cpu").policy if whole_model else TD3Policy.load(path, device="cpu")
    return lambda obs: policy.predict(obs, deterministic=True)[0]


def _run_episode(env: gym.Env, act, seed: int) -> dict:
    obs, info = env.reset(seed=seed)
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(act(obs))
        total += float(reward)
        steps += 1
    return {"seed": seed, "success": bool(terminated), "return": total, "steps": steps,
            "final_distance_m": float(info["distance"])}


def _evaluate_worker(index: int, address: tuple[str, int], episode_steps: int, policy_path: str | None,
                     seeds: list[int], deadline: float | None) -> list[tuple[str, dict]]:
    """Runs on server ``index`` (in a process of its own when there are several): the trained
    policy's episodes on ``seeds`` first (short once it has learnt), then the random policy's on
    the same seeds (each runs all ``episode_steps``), a progress line after each; no episode is
    begun that would end past ``deadline`` (``time.time()``) at 1.25 times the mean time per
    step so far.
    A random policy's actions come from a generator seeded with the episode's seed, so the
    results do not depend on how the seeds were dealt."""
    env = make_env(*address, episode_steps)
    act = load_policy(policy_path) if policy_path else None
    shape = env.action_space.shape
    out: list[tuple[str, dict]] = []
    start, spent, stepped, trained_steps = time.monotonic(), 0.0, 0, 0
    try:
        for name in (("trained", "random") if act is not None else ("random",)):
            for i, seed in enumerate(seeds):
                # the next episode's length: a random one runs them all, a trained one as its longest so far
                steps = trained_steps if name == "trained" and trained_steps else episode_steps
                # its time at the mean s per step so far (resets included), with a quarter more
                if deadline is not None and time.time() + 1.25 * steps * spent / max(stepped, 1) > deadline:
                    print(f"[evaluate] server {index + 1}: {name} policy stopped by --max-minutes after {i} of "
                          f"its {len(seeds)} seeds", flush=True)
                    break
                begun = time.monotonic()
                if name == "trained":
                    e = _run_episode(env, act, seed)
                else:
                    rng = np.random.default_rng(seed)
                    e = _run_episode(env, lambda o, rng=rng: rng.uniform(-1.0, 1.0, shape).astype(np.float32), seed)
                out.append((name, e))
                spent, stepped = spent + time.monotonic() - begun, stepped + e["steps"]
                if name == "trained":
                    trained_steps = max(trained_steps, e["steps"])
                print(f"[evaluate] server {index + 1}: {name} policy, seed {seed}: "
                      f"{'reached' if e['success'] else 'missed'} ({e['steps']} steps, {e['final_distance_m']:.2f} m); "
                      f"{i + 1}/{len(seeds)} of its seeds, {_clock(time.monotonic() - start)}", flush=True)
    finally:
        env.close()
    return out


def summarize(episodes: list[dict], wanted: int) -> dict:
    """Success rate, mean return and final distance of ``episodes``; ``wanted``: how many were asked."""
    n = len(episodes)
    result = {"episodes": n, "successes": sum(e["success"] for e in episodes),
              "success_rate": float(np.mean([e["success"] for e in episodes])) if n else None,
              "mean_return": float(np.mean([e["return"] for e in episodes])) if n else None,
              "mean_final_distance_m": float(np.mean([e["final_distance_m"] for e in episodes])) if n else None}
    if n < wanted:
        result["stopped_by_max_minutes"] = f"{n} of {wanted} episodes run"
    return result


def evaluate(addresses: list[tuple[str, int]], episode_steps: int, policy_path: str | None, episodes: int,
             deadline: float | None, log=print) -> dict:
    """The policy at ``policy_path`` (deterministic), then a random policy, over seeds
    ``EVAL_SEED`` .. ``EVAL_SEED + episodes - 1``, on every server of ``addresses`` in parallel
    (one process each, seeds dealt round-robin), none begun that would end past ``deadline``
    (``time.time()``) at 1.25 times the mean time per step so far, 10 s of it left for ending
    the run."""
    seeds = [EVAL_SEED + i for i in range(episodes)]
    parts = [seeds[k::len(addresses)] for k in range(len(addresses))]
    start = time.monotonic()
    log(f"[evaluate] {episodes} seeded episodes per policy (seeds {seeds[0]}-{seeds[-1]}) on "
        f"{len(addresses)} servers ...")
    # 10 s of the bound left for stopping the workers and the servers and writing the results
    end = None if deadline is None else deadline - 10
    jobs = [(k, a, episode_steps, policy_path, p, end) for k, (a, p) in enumerate(zip(addresses, parts)) if p]
    if len(jobs) == 1:  # one server's work: in this process (a new one would import PyTorch again)
        results = _evaluate_worker(*jobs[0])
    else:
        ctx = multiprocessing.get_context("spawn")  # no forked Zenoh session
        with ProcessPoolExecutor(len(jobs), mp_context=ctx) as pool:
            results = [r for f in [pool.submit(_evaluate_worker, *job) for job in jobs] for r in f.result()]
    by = {name: sorted((e for n, e in results if n == name), key=lambda e: e["seed"]) for name in ("trained", "random")}
    out = {"random": summarize(by["random"], episodes), "eval_wall_s": round(time.monotonic() - start, 1)}
    if policy_path:
        out["trained"] = summarize(by["trained"], episodes)
    log(f"[evaluate] done in {out['eval_wall_s']:.0f} s: " + ", ".join(
        f"{name} {r['successes']}/{r['episodes']} reached" for name, r in out.items() if isinstance(r, dict)))
    return out


def plot(rows: list[dict], selections: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.array([r["env_steps"] for r in rows], dtype=float)
    returns = np.array([r["return"] for r in rows], dtype=float)
    success = np.array([r["success"] for r in rows], dtype=float)
    window = max(1, min(50, len(rows) // 5))
    kernel = np.ones(window) / window
    fig, ax = plt.subplots(figsize=(8, 5.2), dpi=100)
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
    # Below the axes, not over them: the curves and the points fill the whole plot.
    fig.legend(lines[0] + lines2[0], lines[1] + lines2[1], loc="lower center", ncol=2, fontsize=8, frameon=False)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path)
    plt.close(fig)


def _title(result: dict) -> str:
    """The learning curve's title from a run's ``evaluation.json`` content."""
    trained, random_policy = result["trained"], result["random"]
    return (f"DDPG on simx/UR5BallReach-v0 (tutorial state, {result['servers']} servers): evaluation "
            f"{trained['successes']}/{trained['episodes']} reached vs random {random_policy['successes']}/"
            f"{random_policy['episodes']}")


def plot_from(prefix: str) -> Path:
    """Draw a run's learning curve again from its files: ``PREFIX_episodes.csv`` (or
    ``PREFIX/episodes.csv``) and the ``evaluation.json`` beside it; writes and returns
    ``..._learning_curve.png`` (``learning_curve.png`` in a folder)."""
    base = Path(prefix)
    name = (lambda kind: base / kind) if base.is_dir() else (lambda kind: base.with_name(f"{base.name}_{kind}"))
    with open(name("episodes.csv"), newline="") as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    result = json.loads(name("evaluation.json").read_text())
    path = name("learning_curve.png")
    plot(rows, result.get("selection_evaluations", []), path, _title(result))
    return path


def _clock(seconds: float) -> str:
    seconds = max(0, int(seconds))
    return f"{seconds // 60}:{seconds % 60:02d}"


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--servers", type=int, default=2,
                        help="simx-servers = training environments (one more serves the selection evaluations); "
                             "--evaluate: servers evaluating in parallel")
    parser.add_argument("--steps", type=int, default=20_000, help="environment steps to train (all envs)")
    parser.add_argument("--episode-steps", type=int, default=100, help="steps before an episode is truncated")
    parser.add_argument("--learning-starts", type=int, default=1_000, help="random steps before learning")
    parser.add_argument("--eval-episodes", type=int, default=50, help="seeded episodes per policy in the final evaluation")
    parser.add_argument("--select-every", type=int, default=2_000,
                        help="env steps between evaluations that pick the model kept (best mean return)")
    parser.add_argument("--select-episodes", type=int, default=10, help="episodes of each such evaluation")
    parser.add_argument("--max-minutes", type=float, default=None,
                        help="bound on the whole run's wall time (servers' start, training, evaluations); none if not "
                             f"given, {EVALUATE_MINUTES:g} with --evaluate")
    parser.add_argument("--log-every", type=int, default=1_000, help="env steps between progress lines")
    parser.add_argument("--seed", type=int, default=0, help="seed of the training (networks, noise, environments)")
    parser.add_argument("--out", default="runs/ddpg", help="folder for the models, CSV, PNG and JSON")
    parser.add_argument("--quick", action="store_true",
                        help="a short run whose success rate rises within 3-7 minutes on 2 cores, the same episodes and "
                             "result every time: the defaults "
                             "become " + ", ".join(f"--{k.replace('_', '-')} {v}" for k, v in QUICK.items()))
    parser.add_argument("--evaluate", nargs="?", const=str(SHIPPED_POLICY), default=None, metavar="POLICY",
                        help="train nothing: evaluate POLICY (a policy.zip or model.zip; without POLICY the "
                             f"shipped {SHIPPED_POLICY.name}) and a random policy over --eval-episodes seeded episodes")
    parser.add_argument("--plot", metavar="PREFIX",
                        help="train nothing: draw a run's learning curve again from PREFIX_episodes.csv and "
                             "PREFIX_evaluation.json (or a run's --out folder), e.g. docs/training/ddpg_run4")
    args = parser.parse_args(argv)
    if args.evaluate and args.max_minutes is None:
        args.max_minutes = EVALUATE_MINUTES
    if args.quick:  # the preset's values where the command line gave none
        parser.set_defaults(**QUICK)
        args = parser.parse_args(argv)
    return args


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    if args.plot:
        print(f"[plot] wrote {plot_from(args.plot)}")
        return {}
    t0, load_start = time.monotonic(), os.getloadavg()[0]
    deadline = None if args.max_minutes is None else time.time() + 60 * args.max_minutes

    from simx_server.pool import ServerPool

    if args.evaluate:
        if not Path(args.evaluate).is_file():
            sys.exit(f"--evaluate: no policy file {args.evaluate}")
        print(f"[evaluate] starting {args.servers} simx-servers ...", flush=True)
        with ServerPool(args.servers, None, "--speed", "0",
                        progress=lambda line: print(f"[evaluate] {line}", flush=True)) as pool:
            result = {"policy": str(args.evaluate), "env": "simx/UR5BallReach-v0", "episode_steps": args.episode_steps,
                      "eval_seeds": [EVAL_SEED, EVAL_SEED + args.eval_episodes - 1], "servers": args.servers,
                      **evaluate(pool.addresses, args.episode_steps, args.evaluate, args.eval_episodes, deadline),
                      "wall_s": round(time.monotonic() - t0, 1), "machine": machine(load_start)}
        print(json.dumps(result, indent=2))
        return result

    import torch
    from stable_baselines3 import DDPG
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EvalCallback
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    torch.set_num_threads(1)  # small networks: one thread is fastest and leaves the cores to the servers
    # Reproducible training: the seed reaches Python's, NumPy's (replay buffer samples, action
    # noise) and PyTorch's generators, the action space (random actions before learning) and the
    # environments' resets (venv.seed); PyTorch uses only deterministic kernels, on one thread.
    torch.use_deterministic_algorithms(True)
    set_random_seed(args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []

    log = open(out / "episodes.csv", "w", newline="")
    writer = csv.DictWriter(log, ["episode", "env_steps", "return", "length", "success", "wall_s"])
    writer.writeheader()

    class EpisodeLog(BaseCallback):
        """One row per finished training episode (VecMonitor's ``info["episode"]``), written as
        it ends (the CSV can be watched during the training); a progress line every
        ``--log-every`` env steps; stops the training when the evaluations that follow would
        need the time left before ``--max-minutes``."""

        def _on_training_start(self) -> None:
            self.next_line = args.log_every
            self.stop_reason = None
            self.random_phase: tuple[int, float] | None = None  # (steps, s) before learning began
            self.first: tuple[int, float] | None = None  # (steps, time) at the first step, after the resets

        def _on_step(self) -> bool:
            now = time.monotonic()
            if self.random_phase is None and self.num_timesteps >= args.learning_starts:
                self.random_phase = (self.num_timesteps, now - start)
            for info in self.locals["infos"]:
                if "episode" in info:
                    rows.append({"episode": len(rows) + 1, "env_steps": self.num_timesteps,
                                 "return": round(float(info["episode"]["r"]), 4), "length": int(info["episode"]["l"]),
                                 "success": int(bool(info.get("is_success", False))),
                                 "wall_s": round(now - start, 1)})
                    writer.writerow(rows[-1])
                    log.flush()
            rate = self.num_timesteps / max(now - start, 1e-9)
            if self.num_timesteps >= self.next_line:
                self.next_line += args.log_every
                recent = rows[-20:]
                ret = f"{np.mean([r['return'] for r in recent]):.1f}" if recent else "-"
                won = f"{np.mean([r['success'] for r in recent]):.0%}" if recent else "-"
                left = (args.steps - self.num_timesteps) / rate
                if deadline is not None:
                    left = min(left, deadline - time.time() - eval_reserve(rate))
                best = max((float(np.mean(s)) for s in select.evaluations_successes), default=None)
                print(f"[train] {self.num_timesteps:,}/{args.steps:,} steps  {rate:.1f} steps/s  "
                      f"episodes {len(rows)}  last 20: return {ret}, success {won}  "
                      f"best selection {'-' if best is None else f'{best:.0%}'}  elapsed {_clock(now - t0)}  "
                      f"training left ~{_clock(left)}", flush=True)
            if self.first is None:
                self.first = (self.num_timesteps, now)
                print(f"[train] first step done ({_clock(now - t0)} since the start); random actions until "
                      f"{args.learning_starts:,} steps, then learning", flush=True)
            # the reserve from the steps/s measured over 30 s at least (the first resets are slow)
            measured = now - self.first[1] >= 30 and self.num_timesteps > self.first[0]
            if measured:
                rate = (self.num_timesteps - self.first[0]) / (now - self.first[1])
            if deadline is not None and measured and time.time() + eval_reserve(rate) > deadline:
                self.stop_reason = (f"stopped at {self.num_timesteps:,} steps to leave the evaluations "
                                    f"~{_clock(eval_reserve(rate))} of --max-minutes {args.max_minutes:g}")
                print(f"[train] {self.stop_reason}", flush=True)
                return False
            return True

    def eval_reserve(rate: float) -> float:
        """Seconds the final evaluation is expected to take (``rate``: training env steps/s on
        ``--servers`` environments; the evaluation runs on ``--servers`` + 1 servers): a random
        policy's episodes run to ``--episode-steps``, the trained one's as long as the recent
        training episodes; plus 25 s: 15 to start the evaluation's processes, 10 to end the run."""
        recent = rows[-20:]
        trained_len = np.mean([r["length"] for r in recent]) if recent else args.episode_steps
        steps = args.eval_episodes * (args.episode_steps + trained_len)
        return 25.0 + steps / (rate / args.servers * (args.servers + 1))

    # One server more than environments: the model-selection evaluations run on it, beside training.
    print(f"[train] starting {args.servers + 1} simx-servers (each loads the scene and makes its renderers) ...",
          flush=True)
    with ServerPool(args.servers + 1, None, "--speed", "0", progress=lambda line: print(f"[train] {line}", flush=True)) \
            as pool:
        fns = [lambda a=a: make_env(*a, args.episode_steps) for a in pool.addresses[:-1]]
        # One process per environment (spawn: no forked Zenoh session); one environment: this process.
        envs_start = time.monotonic()
        print(f"[train] starting {len(fns)} environment process(es) (each imports MuJoCo's client side and "
              "connects to its server) ...", flush=True)
        venv = VecMonitor(SubprocVecEnv(fns, start_method="spawn") if len(fns) > 1 else DummyVecEnv(fns))
        print(f"[train] environments ready after {time.monotonic() - envs_start:.1f} s", flush=True)
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
        # The same vector-env wrapper as the training's (SB3 warns when they differ).
        select_env = VecMonitor(DummyVecEnv([lambda: make_env(*pool.addresses[-1], args.episode_steps)]))
        select_env.seed(SELECT_SEED)
        select = EvalCallback(select_env, eval_freq=max(1, args.select_every // len(fns)),
                              n_eval_episodes=args.select_episodes, best_model_save_path=str(out),
                              log_path=str(out), deterministic=True, verbose=1)
        episodes = EpisodeLog()
        print(f"[train] DDPG, {args.steps:,} env steps on {args.servers} servers"
              f"{'' if args.max_minutes is None else f', the whole run bounded to {args.max_minutes:g} min'}; "
              f"a line every {args.log_every:,} steps", flush=True)
        start = time.monotonic()
        model.learn(total_timesteps=args.steps, callback=CallbackList([episodes, select]))
        train_s = time.monotonic() - start
        env_steps = model.num_timesteps
        venv.close()
        select_env.close()
        log.close()
        model.save(out / "model_final")
        best = out / "best_model.zip"
        kept = DDPG.load(best, device="cpu") if best.exists() else model
        kept.save(out / "model")
        kept.policy.save(out / "policy.zip")
        selections = [{"env_steps": int(t), "mean_return": round(float(np.mean(r)), 3),
                       "success_rate": float(np.mean(sc)) if len(sc) else None}
                      for t, r, sc in zip(select.evaluations_timesteps, select.evaluations_results,
                                          select.evaluations_successes or [[]] * len(select.evaluations_results))]
        print(f"[train] {env_steps:,} steps in {_clock(train_s)} ({env_steps / train_s:.1f} steps/s); kept: "
              f"{'the best selection evaluation' if kept is not model else 'the final model'}", flush=True)
        evaluation = evaluate(pool.addresses, args.episode_steps, str(out / "policy.zip"), args.eval_episodes,
                              deadline)

    trained, random_policy = evaluation["trained"], evaluation["random"]
    result = {
        "algorithm": "DDPG (stable-baselines3)", "env": "simx/UR5BallReach-v0", "servers": args.servers,
        "seed": args.seed, "episode_steps": args.episode_steps, "train_env_steps": int(env_steps),
        "train_wall_s": round(train_s, 1), "train_episodes": len(rows),
        "env_steps_per_s": round(env_steps / train_s, 1),
        "train_stopped": episodes.stop_reason or "after --steps",
        # the same run's floor: env steps/s while the actions were random and nothing was learnt
        # (the environments alone), and what learning left of it (machine and load independent)
        **_phases(episodes.random_phase, env_steps, train_s),
        "eval_seeds": [EVAL_SEED, EVAL_SEED + args.eval_episodes - 1],
        "trained": trained, "random": random_policy, "eval_wall_s": evaluation["eval_wall_s"],
        "kept_model": "best of the selection evaluations" if kept is not model else "the final model",
        "selection_evaluations": selections, "wall_s": round(time.monotonic() - t0, 1), "machine": machine(load_start),
    }
    (out / "evaluation.json").write_text(json.dumps(result, indent=2) + "\n")
    plot(rows, selections, out / "learning_curve.png", _title(result))
    print(json.dumps(result, indent=2))
    return result


def _phases(random_phase: tuple[int, float] | None, env_steps: int, train_s: float) -> dict:
    if random_phase is None or random_phase[0] >= env_steps or random_phase[1] <= 0:
        return {}
    (n, s), learning = random_phase, (env_steps - random_phase[0]) / (train_s - random_phase[1])
    return {"env_steps_per_s_random_phase": round(n / s, 1), "env_steps_per_s_learning": round(learning, 1),
            "learning_vs_random_phase": round(learning / (n / s), 2)}


def machine(load_start: float) -> str:
    """The machine and its load (1-minute load average at the start and the end): figures of
    one run mean little without them."""
    import importlib.metadata

    try:
        torch = importlib.metadata.version("torch")
    except importlib.metadata.PackageNotFoundError:
        torch = "none"
    return (f"{platform.node()}: {platform.machine()}, {os.cpu_count()} CPUs, load average "
            f"{load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the end, Python {platform.python_version()}, torch {torch}")


if __name__ == "__main__":
    main()
