"""CleanRL's sac_continuous_action.py on mobile_envs under Gymnasium 1.x: its env set-up, its
episode logging and its replay-buffer step with the edits of docs/integrations.md, random
actions (its learning_starts phase) standing in for its actor. tests/test_clients.py runs
this file; the docs page shows its marked sections. Needs stable-baselines3 (its buffer).

    python docs/recipes/cleanrl_sac_continuous_action.py [ENV_ID] [STEPS]
"""

import sys

import gymnasium as gym
import numpy as np
from stable_baselines3.common.buffers import ReplayBuffer


class Writer:
    """Stands in for CleanRL's SummaryWriter: keeps what the script logs."""

    def __init__(self):
        self.scalars = []

    def add_scalar(self, tag, value, step):
        self.scalars.append((tag, float(value), step))


def make_env(env_id, seed, idx, capture_video, run_name):
    def thunk():
        if capture_video and idx == 0:
            env = gym.make(env_id, render_mode="rgb_array")
            env = gym.wrappers.RecordVideo(env, f"videos/{run_name}")
        else:
            env = gym.make(env_id)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env.action_space.seed(seed)
        return env

    return thunk


if __name__ == "__main__":
    env_id = sys.argv[1] if len(sys.argv) > 1 else "mobile_envs:mobile_envs/DiffDrive-Segments-v0"
    total_timesteps = int(sys.argv[2]) if len(sys.argv) > 2 else 500
    num_envs, seed, capture_video, run_name = 2, 1, False, "run"
    writer = Writer()
    # --8<-- [start:envs]
    # Edit 1: same-step autoreset, as Gymnasium 0.29's vector envs did.
    envs = gym.vector.SyncVectorEnv(
        [make_env(env_id, seed + i, i, capture_video, run_name) for i in range(num_envs)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )
    # --8<-- [end:envs]
    envs.single_observation_space.dtype = np.float32
    rb = ReplayBuffer(
        total_timesteps * num_envs,  # transitions: every step of every env is kept
        envs.single_observation_space,
        envs.single_action_space,
        "cpu",
        n_envs=num_envs,
        handle_timeout_termination=False,
    )
    obs, _ = envs.reset(seed=seed)
    for global_step in range(total_timesteps):
        actions = np.array([envs.single_action_space.sample() for _ in range(envs.num_envs)])
        next_obs, rewards, terminations, truncations, infos = envs.step(actions)
        # --8<-- [start:logging]
        # Edit 2: final_info is one dict of arrays, its episodes masked by "_episode".
        if "final_info" in infos:
            final_info = infos["final_info"]
            for idx in np.flatnonzero(final_info.get("_episode", [])):
                episodic_return = final_info["episode"]["r"][idx]
                print(f"global_step={global_step}, episodic_return={episodic_return}")
                writer.add_scalar("charts/episodic_return", episodic_return, global_step)
                episodic_length = final_info["episode"]["l"][idx]
                writer.add_scalar("charts/episodic_length", episodic_length, global_step)
                break

        # Edit 3: an ended episode's last observation is in final_obs (Gymnasium 0.29 called
        # it final_observation), for terminated and truncated episodes alike.
        real_next_obs = next_obs.copy()
        for idx in np.flatnonzero(infos.get("_final_obs", [])):
            real_next_obs[idx] = infos["final_obs"][idx]
        rb.add(obs, real_next_obs, actions, rewards, terminations, infos)
        # --8<-- [end:logging]
        obs = next_obs
    envs.close()
