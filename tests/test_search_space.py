"""agents.sweeps.search_space: YAML spaces become Optuna suggestions that land where their keys say;
the shipped space builds valid PPO models; malformed entries raise naming the parameter."""

import pathlib

import pytest
import sweep_extras  # noqa: F401  (skips this module without the train and sweep extras)

# isort: split
import optuna

from agents.sweeps.search_space import (
    apply_values,
    load_search_space,
    parse_parameter,
    suggest_config,
)
from agents.training.runs import make_training_env, run_config

ROOT = pathlib.Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "hyperparams" / "sweep.yml"
ENV_ID = "mobile_envs/DiffDrive-Random-v0"


def base_config():
    return run_config(ENV_ID, ROOT / "hyperparams" / "ppo.yml", timesteps=1000, n_envs=4)


def test_values_go_into_the_algorithm_and_the_env_by_their_dotted_keys():
    config = base_config()
    updated = apply_values(
        config,
        {
            "learning_rate": 1e-3,
            "policy_kwargs.net_arch": [32],
            "env.reward_weights.heading": 0.7,
        },
    )
    assert updated["ppo"]["learning_rate"] == 1e-3
    log_std_init = config["ppo"]["policy_kwargs"]["log_std_init"]
    assert updated["ppo"]["policy_kwargs"] == {"net_arch": [32], "log_std_init": log_std_init}
    # The entry's own reward weights stay; the swept one is set beside them.
    entry_weights = config.get("env_kwargs", {}).get("reward_weights", {})
    assert "heading" not in entry_weights
    assert updated["env_kwargs"]["reward_weights"] == {**entry_weights, "heading": 0.7}
    assert config["ppo"]["policy_kwargs"]["net_arch"] == [64, 64], "the base stays as it was"


def test_ppo_minibatches_are_capped_at_the_rollout():
    updated = apply_values(base_config(), {"n_steps": 64, "batch_size": 2048})
    assert updated["ppo"]["batch_size"] == 64 * 4


def test_named_choices_store_the_name_and_apply_the_value():
    parameter = parse_parameter(
        "policy_kwargs.net_arch",
        {"type": "categorical", "choices": {"small": [64, 64], "deep": [64, 64, 64]}},
    )
    trial = optuna.trial.FixedTrial({"policy_kwargs.net_arch": "deep"})
    assert parameter.suggest(trial) == [64, 64, 64]
    assert parameter.value_of("small") == [64, 64]


def test_samples_stay_inside_their_ranges():
    int_parameter = parse_parameter("n_epochs", {"type": "int", "low": 3, "high": 5})
    float_parameter = parse_parameter(
        "learning_rate", {"type": "float", "low": 1e-4, "high": 1e-2, "log": True}
    )
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=1))
    for _ in range(50):
        trial = study.ask()
        assert int_parameter.suggest(trial) in (3, 4, 5)
        assert 1e-4 <= float_parameter.suggest(trial) <= 1e-2
        study.tell(trial, 0.0)


def test_the_shipped_space_builds_ppo_models_for_random_trials():
    from stable_baselines3 import PPO

    space = load_search_space(SHIPPED, "ppo")
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for _ in range(3):
        trial = study.ask()
        config = suggest_config(trial, base_config(), space)
        env = make_training_env(config)
        model = PPO(env=env, seed=0, device="cpu", **config["ppo"])
        assert model.learning_rate == trial.params["learning_rate"]
        assert model.batch_size <= model.n_steps * env.num_envs
        weights = env.venv.vector_env.config.reward
        assert weights.cross_track == trial.params["env.reward_weights.cross_track"]
        env.close()
        study.tell(trial, 0.0)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"type": "normal"}, "expected a mapping with type"),
        ({"type": "float", "low": 1.0}, "high must be a float"),
        ({"type": "float", "low": 2.0, "high": 1.0}, "low 2.0 is above high 1.0"),
        ({"type": "float", "low": 0.0, "high": 1.0, "log": True}, "log scale needs low > 0"),
        ({"type": "int", "low": 1.5, "high": 3}, "low must be an int"),
        ({"type": "categorical", "choices": []}, "non-empty list or mapping"),
        ({"type": "categorical", "choices": [[64, 64]]}, "name it"),
        ({"type": "float", "low": 0, "high": 1, "size": 2}, "unknown fields"),
    ],
)
def test_malformed_entries_raise_naming_the_parameter(spec, message):
    with pytest.raises(ValueError, match=rf"'lr'.*{message}"):
        parse_parameter("lr", spec)


def test_a_missing_algorithm_or_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="no search space for algo 'sac'"):
        load_search_space(SHIPPED, "sac")
    with pytest.raises(ValueError, match="search space file not found"):
        load_search_space(tmp_path / "missing.yml", "ppo")
