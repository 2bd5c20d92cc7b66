"""Train PPO (Ray RLlib, new API stack) on simx/UR5BallReach-v0, on one machine or a Ray cluster.

    scripts/install-train.sh ray                                # Ray with RLlib, PyTorch's CPU build
    python examples/train_rllib.py --env-runners 2 --iterations 10          # a local Ray
    python examples/train_rllib.py --address auto --env-runners 4           # a cluster (ray start)

Every env runner makes its environments on its own node, and each environment starts a
simx-server of its own there (``env_config={"servers": "local"}``, simx_client.envs.rllib): no
server is reached from another node, and a server stops with its env runner, also when Ray
kills or restarts that runner. The policy sees the tutorial state (a 7-vector: the ball's pixel
distance and offset from the image centre, its depth, joints 1-3) and moves joints 1-3.

After training it prints, per iteration, the env steps sampled and the mean episode return,
then, for every remote env runner, its node and the servers its environments stepped
(``--json FILE`` writes all of it, for tests and benchmarks).
"""

from __future__ import annotations

import argparse
import json
import time


def build_config(args: argparse.Namespace):
    from ray.rllib.algorithms.ppo import PPOConfig

    from simx_client.envs import rllib

    env_config = {"servers": "local", "max_episode_steps": args.episode_steps}
    batch = args.batch or 200 * max(1, args.env_runners) * args.envs_per_runner
    return (
        PPOConfig()
        .environment(rllib.register(), env_config=env_config)
        .env_runners(num_env_runners=args.env_runners, num_envs_per_env_runner=args.envs_per_runner,
                     num_cpus_per_env_runner=args.cpus_per_runner, rollout_fragment_length="auto")
        .learners(num_learners=0)  # the learner runs in this (the driver's) process
        .training(train_batch_size_per_learner=batch, minibatch_size=min(128, batch), num_epochs=4, lr=3e-4,
                  gamma=0.98)
        .rl_module(model_config={"fcnet_hiddens": [64, 64]})
        .debugging(seed=args.seed)
    )


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", default=None,
                        help="Ray cluster to join ('auto': the one `ray start` made here; default: start a local Ray)")
    parser.add_argument("--env-runners", type=int, default=2, help="remote env runners (0: sample in the driver)")
    parser.add_argument("--envs-per-runner", type=int, default=1, help="environments (= simx-servers) per runner")
    parser.add_argument("--cpus-per-runner", type=float, default=1, help="CPUs Ray reserves for each env runner")
    parser.add_argument("--iterations", type=int, default=10, help="training iterations")
    parser.add_argument("--batch", type=int, default=0, help="env steps per iteration (default 200 per env)")
    parser.add_argument("--episode-steps", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="write the results to this JSON file")
    args = parser.parse_args(argv)

    import ray

    from simx_client.envs import rllib

    began = time.monotonic()
    ray.init(address=args.address, include_dashboard=False, log_to_driver=False)
    try:
        algo = build_config(args).build_algo()
        print(f"Ray joined and PPO built (env runners and their servers started) in "
              f"{time.monotonic() - began:.1f} s", flush=True)
        iterations = []
        start = time.monotonic()
        for i in range(args.iterations):
            result = algo.train()
            runners = result["env_runners"]
            row = {"iteration": i + 1, "env_steps": int(runners.get("num_env_steps_sampled_lifetime", 0)),
                   "episode_return_mean": runners.get("episode_return_mean"),
                   "wall_s": round(time.monotonic() - start, 2),
                   "sample_s": result.get("timers", {}).get("env_runner_sampling_timer")}
            iterations.append(row)
            print(json.dumps(row), flush=True)
        servers = algo.env_runner_group.foreach_env_runner(rllib.servers_of, local_env_runner=False)
        out = {"iterations": iterations, "env_runners": servers,
               "nodes": sorted({s["node_ip"] for runner in servers for s in runner}),
               "env_steps_per_s": iterations[-1]["env_steps"] / iterations[-1]["wall_s"] if iterations else None}
        for runner in servers:
            for s in runner:
                print(f"node {s['node_ip']}: env (pid {s['env_pid']}) -> simx-server pid {s['server_pid']} "
                      f"at {s['host']}:{s['port']}, {s['steps']} steps", flush=True)
        algo.stop()  # closes the env runners' environments: their servers stop
    finally:
        ray.shutdown()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    return out


if __name__ == "__main__":
    main()
