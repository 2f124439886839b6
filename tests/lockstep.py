"""Drive a vector env and the single envs it must equal side by side, bit for bit."""

from collections.abc import Callable

import numpy as np


def drive_in_lockstep(
    vector,
    singles,
    seed: int,
    steps: int,
    actions: Callable[[np.random.Generator], np.ndarray],
    check: Callable[[int, dict, dict], None] | None = None,
) -> int:
    """Reset ``vector`` with ``seed`` and single env i with ``seed + i``, then step them
    together ``steps`` times under ``actions(rng)`` (count, m), each single env restarting
    where the vector env's robot ended (next-step autoreset). Asserts every observation and
    reward equal; ``check(index, vector_infos, single_info)`` adds what the caller compares.

    :return: the episodes that ended
    """
    observations, infos = vector.reset(seed=seed)
    for index, env in enumerate(singles):
        observation, info = env.reset(seed=seed + index)
        np.testing.assert_array_equal(observations[index], observation)
        if check is not None:
            check(index, infos, info)
    rng = np.random.default_rng(2)
    done = np.zeros(len(singles), dtype=bool)
    episodes_ended = 0
    for _ in range(steps):
        step_actions = actions(rng)
        observations, rewards, terminated, truncated, infos = vector.step(step_actions)
        for index, env in enumerate(singles):
            if done[index]:
                single, info = env.reset()
            else:
                single, reward, *_, info = env.step(step_actions[index])
                assert reward == rewards[index]
            np.testing.assert_array_equal(observations[index], single)
            if check is not None:
                check(index, infos, info)
        done = terminated | truncated
        episodes_ended += int(done.sum())
    return episodes_ended
