"""The localization seam: robots observe from what they believe and are scored on the truth."""

import gymnasium as gym
import numpy as np
import pytest
from lockstep import drive_in_lockstep

from mobile_envs.envs.interface import LOCALIZATION_EPISODE_KEYS, LOCALIZATION_INFO_KEYS
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.sensing.localization import Localization, make_localization
from mobile_envs.world.paths import Path

ALONG_X = Path([[0.0, 0.0], [10.0, 0.0]])


class Shifted(Localization):
    """A test localization: the truth shifted sideways by ``offset`` (m), plus Gaussian noise
    of ``sigma`` (m) drawn from each robot's generator."""

    def __init__(self, offset: float = 0.0, sigma: float = 0.0):
        self.offset, self.sigma = offset, sigma

    def reset(self, world, indices, rngs, estimate):
        self.update(world, indices, rngs, estimate)

    def update(self, world, indices, rngs, estimate):
        for index in indices:
            estimate[index] = world.state[index, :3]
            estimate[index, 1] += self.offset + self.sigma * rngs[index].standard_normal()


def test_the_robot_observes_its_belief_and_is_scored_on_the_truth():
    believing = PathFollowingEnv("diff_drive", ALONG_X, localization=Shifted(offset=0.3))
    knowing = PathFollowingEnv("diff_drive", ALONG_X)
    for env in (believing, knowing):
        env.reset(seed=0, options={"start_pose": (0.0, 0.1, 0.0)})
    action = np.array([0.5, 0.5], np.float32)
    believed, reward, *_, info = believing.step(action)
    known, known_reward, *_, known_info = knowing.step(action)
    layout = believing.config.layout
    cte = layout.names.index("cross_track_error")
    # Observed: 0.1 m + 0.3 m left of the path; scored: the true 0.1 m.
    assert believed[cte] == pytest.approx(0.4, abs=1e-6)
    assert known[cte] == pytest.approx(0.1, abs=1e-6)
    assert reward == known_reward
    assert info["cross_track_error"] == known_info["cross_track_error"] == pytest.approx(0.1)
    np.testing.assert_allclose(info["estimated_pose"], info["pose"] + [0.0, 0.3, 0.0])
    assert info["localization_error"] == pytest.approx(0.3)
    assert info["heading_localization_error"] == 0.0
    # The preview points are seen from the believed pose: shifted 0.3 m further right.
    preview = layout.block("path").slice
    np.testing.assert_allclose(
        believed[preview][1:20:2] * (2.5 + 1.0), known[preview][1:20:2] * 3.5 - 0.3, atol=1e-6
    )


def test_exact_localization_is_the_default_and_adds_nothing():
    assert make_localization("exact") is None
    env = PathFollowingEnv("diff_drive", "segments", localization="exact")
    _, info = env.reset(seed=0)
    assert not set(LOCALIZATION_INFO_KEYS) & set(info)


def test_the_episode_metrics_carry_the_localization_error():
    env = PathFollowingEnv("diff_drive", ALONG_X, localization=Shifted(offset=0.2), step_limit=4)
    env.reset(seed=0)
    for _ in range(4):
        *_, truncated, info = env.step(np.array([0.2, 0.2], np.float32))
    assert truncated
    assert info["mean_localization_error"] == pytest.approx(0.2)
    assert info["max_localization_error"] == pytest.approx(0.2)
    assert set(LOCALIZATION_EPISODE_KEYS) <= set(env.episode_metrics())


def test_noisy_beliefs_keep_the_vector_env_equal_to_single_envs():
    settings = {"model": "bicycle", "paths": "training", "start_noise": (0.2, 0.3)}
    vector = PathFollowingVectorEnv(4, **settings, localization=Shifted(sigma=0.05))
    singles = [PathFollowingEnv(**settings, localization=Shifted(sigma=0.05)) for _ in range(4)]

    def same_estimate(index, infos, info):
        np.testing.assert_array_equal(infos["estimated_pose"][index], info["estimated_pose"])
        assert infos["localization_error"][index] == info["localization_error"]

    def actions(rng):
        return rng.uniform(-1, 1, (4, 2)).astype(np.float32)

    drive_in_lockstep(vector, singles, 3, 250, actions, same_estimate)


def test_each_env_works_on_its_own_copy_of_the_localization():
    shared = Shifted(sigma=0.1)
    first = gym.make("mobile_envs/DiffDrive-Lines-v0", localization=shared)
    second = gym.make("mobile_envs/DiffDrive-Lines-v0", localization=shared)
    assert first.unwrapped.core.localization is not second.unwrapped.core.localization


def test_unknown_localizations_and_stray_settings_are_refused():
    with pytest.raises(ValueError, match="unknown localization 'gps'"):
        PathFollowingEnv(localization="gps")
    with pytest.raises(ValueError, match="localization_params"):
        PathFollowingEnv(localization="exact", localization_params={"sigma": 1.0})
    with pytest.raises(ValueError, match="localization must be a Localization"):
        from mobile_envs.sim.config import CoreConfig, build_model, build_path_set

        CoreConfig(build_model("diff_drive"), build_path_set("lines"), localization="odometry")
