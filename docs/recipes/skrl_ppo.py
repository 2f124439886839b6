"""skrl's PPO on mobile_envs' batched vector env, after skrl's own Gymnasium Pendulum example
(examples/gymnasium/torch_gymnasium_pendulum_ppo.py): wrap_env takes gym.make_vec's env as it
is. tests/test_clients.py runs this file with a small TIMESTEPS; docs/integrations.md shows it.

    python docs/recipes/skrl_ppo.py [TIMESTEPS]
"""

import sys

import gymnasium as gym
import torch
import torch.nn as nn
from skrl.agents.torch.ppo import PPO, PPO_CFG
from skrl.envs.wrappers.torch import wrap_env
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
from skrl.trainers.torch import SequentialTrainer
from skrl.utils import set_seed

import mobile_envs  # noqa: F401  (registers the ids)


def mlp(inputs: int, outputs: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(inputs, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh(), nn.Linear(64, outputs)
    )


class Policy(GaussianMixin, Model):
    def __init__(self, **spaces):
        Model.__init__(self, **spaces)
        GaussianMixin.__init__(self, clip_actions=True, reduction="sum")
        # The env's actions are normalized to [-1, 1].
        self.net = nn.Sequential(mlp(self.num_observations, self.num_actions), nn.Tanh())
        self.log_std_parameter = nn.Parameter(torch.full((self.num_actions,), -0.5))

    def compute(self, inputs, role):
        return self.net(inputs["observations"]), {"log_std": self.log_std_parameter}


class Value(DeterministicMixin, Model):
    def __init__(self, **spaces):
        Model.__init__(self, **spaces)
        DeterministicMixin.__init__(self)
        self.net = mlp(self.num_observations, 1)

    def compute(self, inputs, role):
        return self.net(inputs["observations"]), {}


if __name__ == "__main__":
    timesteps = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    torch.set_num_threads(1)
    set_seed(0)
    # 16 robots of the batched vector env, stepped in one call.
    env = wrap_env(gym.make_vec("mobile_envs/DiffDrive-Random-v0", num_envs=16))
    device = env.device
    memory = RandomMemory(memory_size=256, num_envs=env.num_envs, device=device)
    spaces = {
        "observation_space": env.observation_space,
        "state_space": env.state_space,
        "action_space": env.action_space,
        "device": device,
    }
    models = {"policy": Policy(**spaces), "value": Value(**spaces)}
    cfg = PPO_CFG()
    cfg.rollouts = 256
    cfg.learning_epochs = 10
    cfg.mini_batches = 4
    cfg.learning_rate = 3e-4
    cfg.experiment.write_interval = 0  # no TensorBoard files, no checkpoints
    cfg.experiment.checkpoint_interval = 0
    agent = PPO(
        models=models,
        memory=memory,
        cfg=cfg,
        observation_space=env.observation_space,
        state_space=env.state_space,
        action_space=env.action_space,
        device=device,
    )
    trainer = SequentialTrainer(
        cfg={"timesteps": timesteps, "headless": True, "disable_progressbar": True},
        env=env,
        agents=agent,
    )
    trainer.train()
    print("trained skrl's PPO for", timesteps, "vector steps of", env.num_envs, "robots")
