"""TorchRL on mobile_envs: an env by its id with its specs checked, the env's info read into
the tensordicts, serial and parallel batches, and a collector. tests/test_clients.py runs
this file; docs/integrations.md shows it.

    python docs/recipes/torchrl_env.py
"""

import gymnasium as gym
import torch
from torchrl.collectors import Collector
from torchrl.envs import GymEnv, GymWrapper, ParallelEnv, SerialEnv, check_env_specs
from torchrl.envs.libs.gym import default_info_dict_reader

import mobile_envs  # noqa: F401  (registers the ids in this process)
from mobile_envs.envs.recording import UniformInfo

ENV_ID = "mobile_envs/DiffDrive-Segments-v0"


def make_env():
    # The module:id form: worker processes import mobile_envs themselves.
    return GymEnv(f"mobile_envs:{ENV_ID}")


if __name__ == "__main__":
    torch.manual_seed(0)
    env = GymEnv(ENV_ID)
    check_env_specs(env)

    # TorchRL's info reader wants numpy values (it reads value.dtype) and the same keys every
    # step: UniformInfo gives both, the episode metrics NaN until an episode's last step.
    env = GymWrapper(UniformInfo(gym.make(ENV_ID)))
    env.set_info_dict_reader(default_info_dict_reader())
    check_env_specs(env)
    rollout = env.rollout(300, break_when_any_done=True)
    print("rollout of", rollout.batch_size[0], "steps; keys:", sorted(rollout["next"].keys()))
    print("last step: mean |cte|", rollout["next", "mean_abs_cte"][-1].item())

    serial = SerialEnv(4, make_env)
    parallel = ParallelEnv(2, make_env)
    check_env_specs(parallel)
    collector = Collector(serial, policy=None, frames_per_batch=256, total_frames=1024)
    frames = sum(batch.numel() for batch in collector)
    collector.shutdown()
    parallel.close()
    print("collected", frames, "frames from", serial.batch_size[0], "serial envs")
