"""Copies of the envs continue bit for bit like the original: deepcopy, pickle, cloudpickle.

Ray, multiprocessing with spawn or forkserver and SB3's SubprocVecEnv pickle envs; search and
planning code deep-copies them. For every registered id, the single env (through gym.make's
wrappers), the vector env and the SB3 adapter are copied before any reset, right after the
first reset, mid-episode and after episodes have ended and restarted. The truth is the
original itself: each copy is driven by the same actions from the point it was taken, and
every observation, reward, flag and info must equal the original's at the same step.
"""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)

cloudpickle = pytest.importorskip("cloudpickle", reason="cloudpickle copies need cloudpickle")

ALL_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("mobile_envs/"))
COPIERS = {
    "deepcopy": copy.deepcopy,
    "pickle": lambda env: pickle.loads(pickle.dumps(env)),
    "cloudpickle": lambda env: cloudpickle.loads(cloudpickle.dumps(env)),
}
EPISODE_STEPS = 12  # short episodes: the run ends and restarts several of them
STEPS = 40
SEED = 3


def assert_same(got, want, where):
    """Equal, bit for bit, through dicts, lists, tuples, object arrays and None."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and set(got) == set(want), where
        for key, value in want.items():
            assert_same(got[key], value, f"{where}[{key!r}]")
    elif isinstance(want, (list, tuple)):
        assert type(got) is type(want) and len(got) == len(want), where
        for index, (got_item, want_item) in enumerate(zip(got, want, strict=True)):
            assert_same(got_item, want_item, f"{where}[{index}]")
    elif isinstance(want, np.ndarray) and want.dtype == object:
        assert isinstance(got, np.ndarray) and got.shape == want.shape, where
        for index, (got_item, want_item) in enumerate(zip(got, want, strict=True)):
            assert_same(got_item, want_item, f"{where}[{index}]")
    elif want is None:
        assert got is None, where
    else:
        assert type(got) is type(want), f"{where}: {type(got)} is not {type(want)}"
        same = np.shape(got) == np.shape(want) and np.array_equal(got, want)
        if not same or np.asarray(got).dtype != np.asarray(want).dtype:
            np.testing.assert_array_equal(got, want, err_msg=where, strict=True)


def random_actions(shape):
    return np.random.default_rng(0).uniform(-1, 1, (STEPS, *shape)).astype(np.float32)


class SeededRun:
    """What the gym.make and vector env drivers share: the env, random actions for its
    action space and a reset with :data:`SEED`."""

    def __init__(self, env):
        self.env = env
        self.actions = random_actions(env.action_space.shape)

    @staticmethod
    def reset(env):
        return env.reset(seed=SEED)


class SingleRun(SeededRun):
    """gym.make's env (TimeLimit, order enforcing and checker wrappers included), reset by
    the driver when an episode ends."""

    def __init__(self, env_id, **kwargs):
        super().__init__(gym.make(env_id, max_episode_steps=EPISODE_STEPS, **kwargs))

    @staticmethod
    def step(env, action):
        result = env.step(action)
        if result[2] or result[3]:
            return result, env.reset()
        return result, None

    @staticmethod
    def ended(result):
        return result[0][2] or result[0][3]


class VectorRun(SeededRun):
    """The batched vector env in its default NEXT_STEP autoreset mode."""

    def __init__(self, env_id, **kwargs):
        super().__init__(
            gym.make_vec(env_id, num_envs=3, max_episode_steps=EPISODE_STEPS, **kwargs)
        )

    @staticmethod
    def step(env, action):
        return env.step(action)

    @staticmethod
    def ended(result):
        return bool((result[2] | result[3]).any())


class SB3Run:
    """The SB3 adapter (same-step autoreset inside the vector env)."""

    def __init__(self, env_id, **kwargs):
        from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

        self.env = PathFollowingSB3VecEnv(
            env_id, num_envs=3, seed=SEED, max_episode_steps=EPISODE_STEPS, **kwargs
        )
        self.actions = random_actions((3, *self.env.action_space.shape))

    @staticmethod
    def reset(env):
        return env.reset()

    @staticmethod
    def step(env, action):
        return env.step(action)

    @staticmethod
    def ended(result):
        return bool(result[2].any())


def sb3_run(env_id, **kwargs):
    pytest.importorskip("stable_baselines3", reason="the adapter needs the train extra")
    return SB3Run(env_id, **kwargs)


RUNS = {"single": SingleRun, "vector": VectorRun, "sb3": sb3_run}


@pytest.mark.parametrize("kind", list(RUNS))
@pytest.mark.parametrize("env_id", ALL_IDS)
def test_copies_continue_bit_for_bit_like_the_original(env_id, kind):
    assert_copies_continue_like(RUNS[kind](env_id))


def assert_copies_continue_like(run):
    """Copies taken before the first reset, right after it, mid-episode, at a pending
    autoreset and after restarts, each by every copier, continue as ``run.env`` did."""
    original = run.env
    # (step index the copy continues from, copy): the copy's next call is reset() at index
    # -1, else the step of that index.
    copies = [(-1, name, copier(original)) for name, copier in COPIERS.items()]
    reset_result = run.reset(original)
    copies += [(0, name, copier(original)) for name, copier in COPIERS.items()]
    results, first_end = [], None
    for index, action in enumerate(run.actions):
        # Mid-episode; right after the first episode ended (a NEXT_STEP reset pending); and
        # two steps into the episodes that followed.
        if index == 5 or (first_end is not None and index in (first_end + 1, first_end + 3)):
            copies += [(index, name, copier(original)) for name, copier in COPIERS.items()]
        results.append(run.step(original, action))
        if first_end is None and run.ended(results[-1]):
            first_end = index
    assert first_end is not None and first_end + 3 < STEPS, "episodes must end mid-run"

    for start, name, duplicate in copies:
        if start == -1:
            assert_same(run.reset(duplicate), reset_result, f"{name} before reset: reset")
            start = 0
        for index in range(start, STEPS):
            got = run.step(duplicate, run.actions[index])
            assert_same(got, results[index], f"{name} copy taken at step {start}, step {index}")


def test_a_rendering_env_copies_and_renders_the_same_frame():
    pytest.importorskip("pygame", reason="rendering needs pygame (the render extra)")
    env = gym.make("mobile_envs/DiffDrive-Segments-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.array([0.5, 0.6], np.float32))
    frame = env.render()
    duplicate = pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(duplicate.render(), frame)
