"""localization="randomized": each robot draws a localization variant at each reset from its
own generator, keeps it for the episode, and its estimate behaves as that variant's alone."""

from __future__ import annotations

import math
import pathlib
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from lockstep import drive_in_lockstep

from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.sensing.odometry import DEFAULT_K_DISTANCE_HEADING
from mobile_envs.sensing.randomized import DEFAULT_VARIANTS, RandomizedLocalization
from mobile_envs.world.paths import Path

ALONG_X = Path([[0.0, 0.0], [30.0, 0.0]])
ODOMETRY_AT = [
    {"localization": "odometry"},
    {"localization": "odometry", "k_distance_heading": 0.012},
]


def test_each_group_s_heading_error_grows_as_eq_17_predicts_for_its_own_k():
    """20 000 robots drive a straight line at 1 m/s: on a straight line eq. 17's heading
    variance after n steps of dD is n K_Dtheta dD, so the robots that drew the variant with
    four times K_Dtheta spread four times as much, each group within 4.5 standard errors."""
    robots, steps, distance = 20_000, 40, 0.1
    envs = PathFollowingVectorEnv(
        robots, "diff_drive", ALONG_X, localization="randomized",
        localization_params={"variants": ODOMETRY_AT}, step_limit=1000,
    )  # fmt: skip
    envs.reset(seed=3)
    drawn = envs.unwrapped.core.localization.variant_of.copy()
    for _ in range(steps):
        *_, terminated, truncated, infos = envs.step(np.ones((robots, 2), np.float32))
    assert not (terminated | truncated).any()
    errors = infos["heading_localization_error"]
    for variant, k_heading in enumerate((DEFAULT_K_DISTANCE_HEADING, 0.012)):
        group = errors[drawn == variant]
        # Uniform draws: each group holds half the robots, within 5 binomial deviations.
        assert abs(len(group) - robots / 2) < 5 * math.sqrt(robots / 4)
        expected = steps * k_heading * distance
        squares = group**2
        assert abs(squares.mean() - expected) < 4.5 * squares.std() / math.sqrt(len(group))


def test_an_exact_variant_s_robots_know_their_pose_and_the_others_do_not():
    robots = 400
    envs = PathFollowingVectorEnv(
        robots, "diff_drive", "training", localization="randomized", step_limit=200
    )
    envs.reset(seed=0)
    localization = envs.unwrapped.core.localization
    rng = np.random.default_rng(1)
    restarting = np.zeros(robots, dtype=bool)  # next-step autoreset: these only restart
    for _ in range(30):
        *_, terminated, truncated, infos = envs.step(
            rng.uniform(-0.2, 1, (robots, 2)).astype(np.float32)
        )
        moved = ~restarting
        errors = np.abs(infos["estimated_pose"] - infos["pose"]).max(axis=1)
        exact = moved & (localization.variant_of == 0)
        noisiest = moved & (localization.variant_of == 2)
        assert exact.any() and (errors[exact] == 0).all()
        assert noisiest.any() and (errors[noisiest] > 0).all()  # and a noisy head
        restarting = terminated | truncated


def test_the_vector_env_equals_single_envs_bit_for_bit_through_restarts():
    settings = {"model": "bicycle", "paths": "training", "start_noise": (0.2, 0.3)}
    count = 4
    vector = PathFollowingVectorEnv(count, **settings, localization="randomized", step_limit=40)
    singles = [
        PathFollowingEnv(**settings, localization="randomized", step_limit=40) for _ in range(count)
    ]
    variants_seen = set()

    def same_estimate_and_variant(index, infos, info):
        np.testing.assert_array_equal(infos["estimated_pose"][index], info["estimated_pose"])
        drawn = singles[index].core.localization.variant_of[0]
        assert vector.core.localization.variant_of[index] == drawn
        variants_seen.add(int(drawn))

    def actions(rng):
        return rng.uniform(-0.2, 1, (count, 2)).astype(np.float32)

    assert drive_in_lockstep(vector, singles, 5, 150, actions, same_estimate_and_variant) > count
    assert variants_seen == set(range(len(DEFAULT_VARIANTS)))


def test_the_checkers_pass_and_the_same_seed_gives_the_same_bits():
    sb3_checker = pytest.importorskip(
        "stable_baselines3.common.env_checker", reason="SB3's checker needs the train extra"
    )
    env = gym.make("mobile_envs/Tricycle-Random-v0", localization="randomized")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_checker.check_env(env.unwrapped, warn=True)

    def estimates(seed):
        env.reset(seed=seed)
        return [env.step(np.array([0.6, 0.1], np.float32))[-1]["estimated_pose"] for _ in range(30)]

    np.testing.assert_array_equal(estimates(4), estimates(4))


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"variants": []}, "at least one variant"),
        ({"variants": "odometry"}, "must be a list of mappings"),
        ({"variants": ["odometry"]}, r"variants\[0\] must be a mapping"),
        ({"variants": [{"k_distance": 0.1}]}, r"variants\[0\] needs 'localization'"),
        (
            {"variants": [{"localization": "exact"}, {"localization": "randomized"}]},
            r"variants\[1\]: a randomized",
        ),
        (
            {"variants": [{"localization": "odometry", "k_distance": -1.0}]},
            r"variants\[0\]: .*k_distance",
        ),
        ({"variants": [{"localization": "odometry", "speed": 1.0}]}, r"variants\[0\]: .*speed"),
        (
            {
                "variants": [
                    {"localization": "exact"},
                    {"localization": "odometry", "steering_counts": 4096},
                ]
            },
            "steering_counts",
        ),
    ],
)
def test_bad_variants_raise_value_errors_naming_them(params, message):
    with pytest.raises(ValueError, match=message):
        PathFollowingEnv(
            "tricycle", "training", localization="randomized", localization_params=params
        )


def test_a_variant_the_model_cannot_run_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"variants\[1\]: .*wheels"):
        PathFollowingEnv(
            "constant_velocity", "training", localization="randomized",
            localization_params={
                "variants": [{"localization": "beacons"}, {"localization": "odometry"}]
            },
        )  # fmt: skip


def test_the_default_variants_are_exact_and_two_noise_levels_of_the_seeds_fusion():
    localization = RandomizedLocalization()
    names = [settings["localization"] for settings in localization.settings]
    assert names == ["exact", "odometry+beacons", "odometry+beacons"]
    assert [settings.get("k_distance_heading") for settings in localization.settings] == [
        None, None, 2 * DEFAULT_K_DISTANCE_HEADING,
    ]  # fmt: skip
    assert localization.settings[2]["bearing_noise"] == 0.001


def test_every_recipe_of_the_randomized_hyperparams_makes_an_env_that_steps():
    """hyperparams/ppo_randomized.yml: every model's training env, variants included (the
    constant-velocity robot's beacons alone), builds and steps."""
    yaml = pytest.importorskip("yaml", reason="hyperparams are YAML (the train extra)")
    root = pathlib.Path(__file__).resolve().parents[1]
    entries = yaml.safe_load((root / "hyperparams" / "ppo_randomized.yml").read_text())
    random_ids = [key for key in entries if key.endswith("-Random-v0")]
    assert len(random_ids) == 4
    for env_id in random_ids:
        env_kwargs = entries[env_id]["env_kwargs"]
        assert env_kwargs["localization"] == "randomized"
        env = gym.make(env_id, **env_kwargs)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
