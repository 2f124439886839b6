"""CleanRL's ppo_continuous_action.py on mobile_envs under Gymnasium 1.x: its env set-up and its
episode logging with the three edits of docs/integrations.md, random actions standing in for
its agent. tests/test_clients.py runs this file; the docs page shows its marked sections.

    python docs/recipes/cleanrl_ppo_continuous_action.py [ENV_ID] [ITERATIONS]
"""

import sys

import gymnasium as gym
import numpy as np


class Writer:
    """Stands in for CleanRL's SummaryWriter: keeps what the script logs."""

    def __init__(self):
        self.scalars = []

    def add_scalar(self, tag, value, step):
        self.scalars.append((tag, float(value), step))


# --8<-- [start:make_env]
def make_env(env_id, idx, capture_video, run_name, gamma):
    def thunk():
        if capture_video and idx == 0:
            env = gym.make(env_id, render_mode="rgb_array")
            env = gym.wrappers.RecordVideo(env, f"videos/{run_name}")
        else:
            env = gym.make(env_id)
        env = gym.wrappers.FlattenObservation(env)  # deal with dm_control's Dict observation space
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        # Edit 1: Gymnasium 1.x's TransformObservation takes the observation space.
        env = gym.wrappers.TransformObservation(
            env, lambda obs: np.clip(obs, -10, 10), env.observation_space
        )
        env = gym.wrappers.NormalizeReward(env, gamma=gamma)
        env = gym.wrappers.TransformReward(env, lambda reward: np.clip(reward, -10, 10))
        return env

    return thunk
    # --8<-- [end:make_env]


if __name__ == "__main__":
    env_id = sys.argv[1] if len(sys.argv) > 1 else "mobile_envs:mobile_envs/DiffDrive-Segments-v0"
    num_iterations = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    num_envs, num_steps, seed, gamma, capture_video, run_name = 2, 200, 1, 0.99, False, "run"
    writer = Writer()
    # --8<-- [start:envs]
    # Edit 2: same-step autoreset, as Gymnasium 0.29's vector envs did (Gymnasium 1.x's
    # default, next-step, gives no final_info and adds a reset step after each episode).
    envs = gym.vector.SyncVectorEnv(
        [make_env(env_id, i, capture_video, run_name, gamma) for i in range(num_envs)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )
    # --8<-- [end:envs]
    next_obs, _ = envs.reset(seed=seed)
    envs.action_space.seed(seed)
    global_step = 0
    for _iteration in range(1, num_iterations + 1):
        for _step in range(0, num_steps):
            global_step += num_envs
            action = envs.action_space.sample()  # CleanRL: agent.get_action_and_value(next_obs)
            next_obs, reward, terminations, truncations, infos = envs.step(action)
            # --8<-- [start:logging]
            # Edit 3: final_info is one dict of arrays, its episodes masked by "_episode".
            if "final_info" in infos:
                final_info = infos["final_info"]
                for idx in np.flatnonzero(final_info.get("_episode", [])):
                    episodic_return = final_info["episode"]["r"][idx]
                    print(f"global_step={global_step}, episodic_return={episodic_return}")
                    writer.add_scalar("charts/episodic_return", episodic_return, global_step)
                    episodic_length = final_info["episode"]["l"][idx]
                    writer.add_scalar("charts/episodic_length", episodic_length, global_step)
            # --8<-- [end:logging]
    envs.close()
