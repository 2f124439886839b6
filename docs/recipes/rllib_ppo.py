"""RLlib's PPO on a mobile_envs id: the ``module:id`` form, so that every env runner (a separate
Ray worker process) imports mobile_envs itself; the bare id fails in the workers. RLlib 2.60
pins gymnasium 1.2.2, so it lives in a virtual environment of its own (docs/integrations.md);
this file is the recipe's check, run there:

    python docs/recipes/rllib_ppo.py [ITERATIONS]
"""

import sys

import ray
from ray.rllib.algorithms.ppo import PPOConfig

if __name__ == "__main__":
    iterations = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    ray.init(num_cpus=2, include_dashboard=False)
    config = (
        PPOConfig()
        .environment("mobile_envs:mobile_envs/DiffDrive-Segments-v0")
        .env_runners(num_env_runners=1, num_envs_per_env_runner=4)
        .training(train_batch_size_per_learner=2000, minibatch_size=250, num_epochs=4)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    for iteration in range(1, iterations + 1):
        result = algo.train()
        runners = result["env_runners"]
        print(
            f"iteration {iteration}: {runners['num_env_steps_sampled_lifetime']} steps, "
            f"mean episode return {runners.get('episode_return_mean', float('nan')):.2f}",
            flush=True,
        )
    algo.stop()
    ray.shutdown()
