"""Training runs as a library: the settings of a run, and a run folder trained to the end.

The sweep (:mod:`agents.sweeps.sweep`) and the grid (:mod:`agents.grid.grid`) train many runs; each
one is a run folder exactly like ``python train.py``'s, so ``python train.py --resume FOLDER`` and
``python train.py evaluate --model FOLDER/final_model.zip`` work on any of them:

- ``config.yml``: the resolved settings (:func:`run_config`), the schema train.py writes
- ``machine.yml``: the machine and libraries of each training session
  (:mod:`agents.training.machine`)
- ``checkpoints/latest.zip``: written atomically every ``checkpoint_freq`` steps and at the end,
  with ``checkpoints/replay_buffer_STEPS.pkl`` beside it for the off-policy algorithms
- ``final_model.zip``, and ``best_model.zip`` when a harness evaluation ran

Four algorithms (:data:`ALGORITHMS`): PPO, and the off-policy SAC, TD3 (Stable-Baselines3)
and TQC (sb3-contrib). A run's settings for its algorithm live under ``config[algo]``; two
keys there are train.py's, not the algorithm's, as in rl-baselines3-zoo: ``noise_type``
(``normal`` or ``ornstein-uhlenbeck``) and ``noise_std`` make the exploration noise
(``action_noise``) of the off-policy algorithms. A hyperparameter entry's warm start goes to
``config["warm_start"]``: written as rl-baselines3-zoo's ``callback:`` entry naming
:class:`agents.training.imitation.WarmStartCallback` (as ``hyperparams/ppo.yml`` has it, so the
zoo runs the same file), or as a ``warm_start:`` mapping (train.py's own form, which the zoo
does not know). A new run hands it to ``agents.training.imitation.warm_start`` before training
(:func:`build_model`), keeping its progress in ``checkpoints/warm_start.pkl``
(:func:`warm_start_checkpoint`), so that a run stopped during the warm start resumes it.

Requires the ``train`` extra (stable-baselines3, sb3-contrib, torch, PyYAML).
"""

from __future__ import annotations

import copy
import math
import pathlib
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from agents.harness.policies import ALGORITHMS, algorithm_class, observation_settings

if TYPE_CHECKING:  # PyYAML, torch and SB3 load when a run is built, not for ALGORITHMS
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.interrupts import StopRequests

#: Those that learn from a replay buffer, which their checkpoints save beside the model.
OFF_POLICY = ("sac", "td3", "tqc")
#: Settings in an algorithm's section that train.py turns into an argument (``action_noise``).
NOISE_SETTINGS = ("noise_type", "noise_std")
NOISE_TYPES = ("normal", "ornstein-uhlenbeck")
#: The bounds of the algorithms' numeric settings, (low, high), inclusive; a setting whose
#: default is a number and that is not listed only has to be a number of that kind.
SETTING_BOUNDS: dict[str, tuple[float, float]] = {
    "learning_rate": (math.ulp(0.0), math.inf),
    "n_steps": (1, math.inf),
    "batch_size": (1, math.inf),
    "n_epochs": (1, math.inf),
    "buffer_size": (1, math.inf),
    "learning_starts": (0, math.inf),
    "gamma": (0.0, 1.0),
    "gae_lambda": (0.0, 1.0),
    "tau": (0.0, 1.0),
    "clip_range": (math.ulp(0.0), math.inf),
    "vf_coef": (0.0, math.inf),
    "ent_coef": (0.0, math.inf),
    "max_grad_norm": (math.ulp(0.0), math.inf),
    "gradient_steps": (-1, math.inf),
    "train_freq": (1, math.inf),
    "target_update_interval": (1, math.inf),
    "policy_delay": (1, math.inf),
    "target_policy_noise": (0.0, math.inf),
    "target_noise_clip": (0.0, math.inf),
    "top_quantiles_to_drop_per_net": (0, math.inf),
    "sde_sample_freq": (-1, math.inf),
}
#: Settings that also take a word: SAC's and TQC's ``ent_coef`` ("auto", "auto_0.1").
WORD_SETTINGS = {"ent_coef": "auto"}
#: Settings that also take a linear schedule written as rl-baselines3-zoo writes it:
#: ``lin_3e-4`` starts at 3e-4 and falls linearly to 0 at the run's last step.
SCHEDULE_SETTINGS = ("learning_rate", "clip_range")
LINEAR_PREFIX = "lin_"


def linear_start(value: object) -> float | None:
    """The starting value of a ``lin_<number>`` setting, or None when ``value`` is not one
    (a number, or a word that is not ``lin_`` followed by a finite number)."""
    if not isinstance(value, str) or not value.startswith(LINEAR_PREFIX):
        return None
    try:
        start = float(value[len(LINEAR_PREFIX) :])
    except ValueError:
        return None
    return start if math.isfinite(start) else None


def with_schedules(settings: dict[str, Any]) -> dict[str, Any]:
    """``settings`` with each ``lin_<number>`` of :data:`SCHEDULE_SETTINGS` turned into SB3's
    ``LinearSchedule`` from that number to 0 over the run (a picklable schedule, so a saved
    model and a resumed run keep it: SB3 feeds it the fraction of the run remaining)."""
    from stable_baselines3.common.utils import LinearSchedule

    scheduled = dict(settings)
    for name in SCHEDULE_SETTINGS:
        start = linear_start(scheduled.get(name))
        if start is not None:
            scheduled[name] = LinearSchedule(start, 0.0, 1.0)
    return scheduled


def check_algorithm_settings(algo: str, settings: dict[str, Any], source: object) -> None:
    """ValueError naming ``source`` for a setting ``algo``'s class does not take, one train.py
    sets itself, or a malformed exploration noise.

    :param algo: one of :data:`ALGORITHMS`
    :param settings: the run's ``config[algo]``
    :param source: the file (or flag) the settings came from, for the message
    """
    import inspect

    own = {"env", "seed", "device", "verbose", "tensorboard_log"}
    reserved = sorted(set(settings) & own)
    if reserved:
        raise ValueError(f"{source}: {', '.join(reserved)} is set by train.py, not in the YAML")
    extra = set(NOISE_SETTINGS) if algo in OFF_POLICY else set()
    accepted = set(inspect.signature(algorithm_class(algo)).parameters) | extra
    unknown = sorted(set(settings) - accepted)
    if unknown:
        raise ValueError(f"{source}: {algo.upper()} has no setting {', '.join(map(repr, unknown))}")
    if "noise_type" in settings:
        if settings["noise_type"] not in NOISE_TYPES:
            raise ValueError(
                f"{source}: noise_type must be one of {NOISE_TYPES}, got {settings['noise_type']!r}"
            )
        if "action_noise" in settings:
            raise ValueError(f"{source}: give noise_type or action_noise, not both")
        std = settings.get("noise_std", 0.1)
        if isinstance(std, bool) or not isinstance(std, (int, float)) or not std > 0:
            raise ValueError(f"{source}: noise_std must be a positive number, got {std!r}")
    elif "noise_std" in settings:
        raise ValueError(f"{source}: noise_std needs a noise_type ({', '.join(NOISE_TYPES)})")
    defaults = {
        name: parameter.default
        for name, parameter in inspect.signature(algorithm_class(algo)).parameters.items()
    }
    for name, value in settings.items():
        _check_value(name, value, defaults.get(name), source)
    if "policy_kwargs" in settings:
        _check_policy_kwargs(settings["policy_kwargs"], source)
    if "policy" in settings:
        policy_class(algo, settings["policy"], source)


def _is_number(value: object, whole: bool = False) -> bool:
    """Whether ``value`` is a finite real number (a whole one with ``whole``), not a bool."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return math.isfinite(value) and (not whole or float(value).is_integer())


def _check_value(name: str, value: object, default: object, source: object) -> None:
    """ValueError naming ``source`` and the setting when ``value`` is not the kind of number
    its default is, or lies outside :data:`SETTING_BOUNDS`."""
    word = WORD_SETTINGS.get(name)
    if word is not None and isinstance(value, str) and value.startswith(word):
        return
    if name in SCHEDULE_SETTINGS and isinstance(value, str):
        start = linear_start(value)
        if start is None:
            raise ValueError(
                f"{source}: {name} must be a finite number or {LINEAR_PREFIX}<number> "
                f"(a linear schedule such as {LINEAR_PREFIX}3e-4), got {value!r:.60}"
            )
        value = start  # its start must lie within the setting's bounds
    if name == "train_freq" and isinstance(value, (list, tuple)):
        if len(value) != 2 or not _is_number(value[0], whole=True) or value[0] < 1:
            raise ValueError(f"{source}: train_freq must be N >= 1 or [N, 'step' or 'episode']")
        if value[1] not in ("step", "episode"):
            raise ValueError(f"{source}: train_freq's unit must be 'step' or 'episode'")
        return
    numeric = name in SETTING_BOUNDS or (
        isinstance(default, (int, float)) and not isinstance(default, bool)
    )
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{source}: {name} must be true or false, got {value!r:.60}")
        return
    if not numeric:
        return
    whole = isinstance(default, int) and name != "learning_rate"
    if not _is_number(value, whole):
        kind = "a whole number" if whole else "a finite number"
        raise ValueError(f"{source}: {name} must be {kind}, got {value!r:.60}")
    assert isinstance(value, (int, float))
    low, high = SETTING_BOUNDS.get(name, (-math.inf, math.inf))
    if not low <= value <= high:
        above = f"at least {low:g}" if high == math.inf else f"in [{low:g}, {high:g}]"
        raise ValueError(f"{source}: {name} must be {above}, got {value!r}")


def policy_class(algo: str, policy: object, source: object) -> Any:
    """The policy an entry's ``policy`` names: one of the algorithm's aliases (``MlpPolicy``)
    as it is, or the class at a dotted import path (rl-baselines3-zoo imports those too), such
    as ``agents.training.speed_floor.SpeedFloorPolicy``.

    :raises ValueError: naming ``source`` for an unknown alias, a path that does not import,
        or a class that is not a policy of ``algo``
    """
    import importlib

    aliases = algorithm_class(algo).policy_aliases
    if isinstance(policy, str) and policy in aliases:
        return policy
    if not isinstance(policy, str) or "." not in policy:
        raise ValueError(
            f"{source}: policy must be one of {', '.join(sorted(aliases))} or the import path "
            f"of a policy class (module.Class), got {policy!r:.80}"
        )
    module, _, name = policy.rpartition(".")
    try:
        found = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"{source}: policy {policy!r} does not import: {error}") from None
    base = aliases["MlpPolicy"]
    if not (isinstance(found, type) and issubclass(found, base)):
        raise ValueError(
            f"{source}: policy {policy!r} is not a {algo.upper()} policy (a subclass of "
            f"{base.__module__}.{base.__name__})"
        )
    return found


def _check_policy_kwargs(policy_kwargs: object, source: object) -> None:
    """ValueError naming ``source`` for ``policy_kwargs`` that is not a mapping, or a
    ``net_arch`` that is not a list of layer widths (or a mapping of pi, vf, qf to such lists)."""
    if not isinstance(policy_kwargs, dict):
        raise ValueError(f"{source}: policy_kwargs must be a mapping, got {policy_kwargs!r:.60}")
    if "net_arch" not in policy_kwargs:
        return
    net_arch = policy_kwargs["net_arch"]
    layers = net_arch.values() if isinstance(net_arch, dict) else [net_arch]
    widths_ok = isinstance(net_arch, (list, dict)) and all(
        isinstance(widths, list)
        and all(_is_number(width, whole=True) and width >= 1 for width in widths)
        for widths in layers
    )
    if not widths_ok or (isinstance(net_arch, dict) and set(net_arch) - {"pi", "vf", "qf"}):
        raise ValueError(
            f"{source}: policy_kwargs.net_arch must be a list of layer widths such as [64, 64], "
            f"or a mapping of pi, vf and qf to such lists, got {net_arch!r:.60}"
        )


def check_model_builds(config: dict[str, Any], source: object) -> None:
    """Build the run's model once on its env, without its warm start, so that settings the
    algorithm itself refuses are reported before anything trains.

    :raises ValueError: naming ``source`` with the algorithm's own complaint
    """
    trial = {key: value for key, value in config.items() if key != "warm_start"}
    env = make_training_env(trial)
    try:
        build_model(trial, env)
    except Exception as error:  # SB3's AssertionError, TypeError and ValueError alike
        raise ValueError(
            f"{source}: {config.get('algo', 'ppo').upper()} refuses these settings: "
            f"{type(error).__name__}: {error}"
        ) from None
    finally:
        env.close()


def check_env_kwargs(env_id: str, config: dict[str, Any], source: object) -> None:
    """Make ``env_id`` once with the run's ``env_kwargs``, so that a bad one is reported
    before anything trains.

    :raises ValueError: naming ``source`` and the env's complaint
    """
    import gymnasium as gym

    import mobile_envs  # noqa: F401  (registers the ids)

    try:
        env = gym.make(env_id, **env_kwargs_for(config))
    except (TypeError, ValueError, OverflowError) as error:
        raise ValueError(f"{source} for {env_id}: {error}") from None
    env.close()


def action_noise(settings: dict[str, Any], n_actions: int) -> Any:
    """The exploration noise ``noise_type`` and ``noise_std`` ask for (None without them).

    :param settings: an algorithm's section of a run config
    :param n_actions: the size of the action space
    """
    import numpy as np
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    kind = settings.get("noise_type")
    if kind is None:
        return None
    mean = np.zeros(n_actions)
    sigma = float(settings.get("noise_std", 0.1)) * np.ones(n_actions)
    if kind == "normal":
        return NormalActionNoise(mean, sigma)
    return OrnsteinUhlenbeckActionNoise(mean, sigma)


#: The hyperparameter files: ``ALGO.yml``, an entry per env id, and ``sweep.yml``, the
#: sweeps' search spaces.
HYPERPARAMS = pathlib.Path(__file__).resolve().parents[2] / "hyperparams"


def default_hyperparams(algo: str) -> pathlib.Path:
    """The hyperparameter file a run of ``algo`` reads unless told otherwise:
    ``hyperparams/ALGO.yml``."""
    return HYPERPARAMS / f"{algo}.yml"


def hyperparameter_entry(hyperparams: pathlib.Path, env_id: str) -> dict[str, Any]:
    """The entry for ``env_id`` in a hyperparameter YAML (``hyperparams/ppo.yml``), or its
    ``default`` entry.

    :raises ValueError: for a missing file or a file with neither entry
    """
    if not hyperparams.is_file():
        raise ValueError(f"hyperparameter file not found: {hyperparams}")
    import yaml

    try:
        table = yaml.safe_load(hyperparams.read_text(encoding="utf-8")) or {}
    except (UnicodeDecodeError, yaml.YAMLError) as error:
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ValueError(f"{hyperparams} is not valid YAML: {problem}") from None
    if not isinstance(table, dict):
        raise ValueError(f"{hyperparams} must map env ids to settings, got {table!r:.60}")
    if env_id not in table and "default" not in table:
        raise ValueError(f"{hyperparams} has no entry for {env_id} and no 'default'")
    entry = table[env_id] if env_id in table else table["default"]
    if not isinstance(entry, dict):
        raise ValueError(f"{hyperparams}: the entry for {env_id} must be a mapping")
    return copy.deepcopy(dict(entry))


def run_config(
    env_id: str,
    hyperparams: pathlib.Path,
    *,
    algo: str = "ppo",
    seed: int = 0,
    timesteps: int | None = None,
    n_envs: int | None = None,
    eval_freq: int = 0,
    eval_episodes: int = 10,
    checkpoint_freq: int = 0,
) -> dict[str, Any]:
    """The settings of a new run, as train.py resolves them: the YAML entry, then overrides.

    :param env_id: the registered env id to train on
    :param hyperparams: the hyperparameter YAML for ``algo``
    :param algo: one of :data:`ALGORITHMS`; its keyword arguments go under ``config[algo]``
    :param timesteps: total steps (default: the entry's ``n_timesteps``)
    :param n_envs: robots collecting experience (default: the entry's ``n_envs``)
    :param eval_freq: steps between harness evaluations during training (0: none)
    :param eval_episodes: episodes per evaluation
    :param checkpoint_freq: steps between checkpoints (0: only the one at the end)
    """
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algo {algo!r}; known: {', '.join(ALGORITHMS)}")
    entry = hyperparameter_entry(hyperparams, env_id)
    entry_timesteps = entry.pop("n_timesteps", 1_000_000)
    entry_n_envs = entry.pop("n_envs", 16)
    config = {
        "env": env_id,
        "algo": algo,
        "seed": int(seed),
        "timesteps": int(timesteps or entry_timesteps),
        "n_envs": int(n_envs or entry_n_envs),
        "env_kwargs": entry.pop("env_kwargs", {}),
        "vec_env": "native",
        "eval_freq": int(eval_freq),
        "eval_episodes": int(eval_episodes),
        "checkpoint_freq": int(checkpoint_freq),
    }
    warm_start = pop_warm_start(entry, hyperparams)
    if warm_start is not None:
        config["warm_start"] = warm_start
    config[algo] = entry
    for name in ("timesteps", "n_envs"):
        if config[name] < 1:
            raise ValueError(f"{name} must be at least 1, got {config[name]}")
    return config


#: The rl-baselines3-zoo callback that is a warm start (see :func:`pop_warm_start`).
WARM_START_CALLBACK = "agents.training.imitation.WarmStartCallback"


def pop_warm_start(settings: dict[str, Any], source: object) -> dict[str, Any] | None:
    """Remove and return the warm start of a hyperparameter entry (None if absent): its
    ``warm_start`` mapping, or the settings of its rl-baselines3-zoo ``callback:`` entry
    naming :data:`WARM_START_CALLBACK` (a name, or a one-key mapping of the name to its
    keyword arguments, alone or in a list).

    :raises ValueError: naming ``source`` for a warm start that is not a mapping, a callback
        train.py does not run (train.py runs no other zoo callback), or both forms at once
    """
    warm_start = settings.pop("warm_start", None)
    if warm_start is not None and not isinstance(warm_start, dict):
        raise ValueError(f"{source}: warm_start must be a mapping, got {warm_start!r:.60}")
    if "callback" not in settings:
        return warm_start
    callbacks = settings.pop("callback")
    entries = callbacks if isinstance(callbacks, list) else [callbacks]
    found = []
    for entry in entries:
        name, kwargs = (entry, {}) if isinstance(entry, str) else _one_key(entry, source)
        if name != WARM_START_CALLBACK or not isinstance(kwargs, dict):
            raise ValueError(
                f"{source}: callback {entry!r:.80} is not one train.py runs; it runs "
                f"{WARM_START_CALLBACK} (a mapping of its settings) and no other"
            )
        found.append(dict(kwargs))
    if len(found) > 1 or (found and warm_start is not None):
        raise ValueError(f"{source}: give one warm start, as warm_start or as its callback")
    return found[0] if found else warm_start


def _one_key(entry: object, source: object) -> tuple[str, Any]:
    """The (name, keyword arguments) of a zoo callback entry ``{name: kwargs}``."""
    if not isinstance(entry, dict) or len(entry) != 1:
        raise ValueError(
            f"{source}: a callback entry must be a name or {{name: settings}}, got {entry!r:.80}"
        )
    return next(iter(entry.items()))


def warm_start_checkpoint(folder: pathlib.Path) -> pathlib.Path:
    """Where a run keeps its warm start's progress, then its cloned weights:
    ``checkpoints/warm_start.pkl``. A folder with it and ``config.yml`` but no
    ``checkpoints/latest.zip`` is a run stopped during its warm start."""
    return folder / "checkpoints" / "warm_start.pkl"


def env_kwargs_for(config: dict[str, Any]) -> dict[str, Any]:
    """The run's ``env_kwargs`` as the environment takes them: a ``reward_weights`` mapping
    (as YAML stores it) becomes a :class:`~mobile_envs.sim.config.RewardWeights`.

    :raises ValueError: for a reward weight the environment does not have
    """
    from mobile_envs.sim.config import RewardWeights

    kwargs = dict(config.get("env_kwargs") or {})
    weights = kwargs.get("reward_weights")
    if isinstance(weights, dict):
        known = set(RewardWeights.__dataclass_fields__)
        unknown = sorted(set(weights) - known)
        if unknown:
            raise ValueError(f"unknown reward weights {unknown}; known: {sorted(known)}")
        kwargs["reward_weights"] = RewardWeights(**{**vars(RewardWeights()), **weights})
    return kwargs


def make_training_env(config: dict[str, Any]) -> Any:
    """The VecEnv a run collects experience from, seeded from the run's seed."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecMonitor

    import mobile_envs  # noqa: F401  (registers the ids)
    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    if config.get("vec_env", "native") == "native":
        env = PathFollowingSB3VecEnv(
            config["env"], config["n_envs"], seed=config["seed"], **env_kwargs_for(config)
        )
        return VecMonitor(env, info_keywords=("is_success",))
    return make_vec_env(
        config["env"],
        n_envs=config["n_envs"],
        seed=config["seed"],
        env_kwargs=env_kwargs_for(config),
        monitor_kwargs={"info_keywords": ("is_success",)},
    )


def write_config(folder: pathlib.Path, config: dict[str, Any]) -> None:
    """Write ``config.yml`` into a new run folder."""
    import yaml

    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yml").write_text(yaml.safe_dump(config, sort_keys=False))


def label_policy(model: Any, config: dict[str, Any]) -> None:
    """Record in ``model``, saved with it, the env id it trains on (which tells the harness
    its kinematic model) and the observation settings it trains with (the sensors: the
    harness makes the envs it evaluates the policy in with them; see
    :data:`agents.harness.policies.OBSERVATION_SETTINGS`)."""
    model.trained_on = config["env"]
    model.observation_settings = observation_settings(config.get("env_kwargs") or {})


def build_model(
    config: dict[str, Any],
    env: Any,
    *,
    tensorboard_log: str | None = None,
    check_stop: Callable[[], None] | None = None,
    warm_start_file: pathlib.Path | None = None,
    progress: bool = False,
    label: str = "",
) -> BaseAlgorithm:
    """A new model of the run's algorithm on ``env``, warm-started when the config says so.

    With a ``warm_start`` mapping in ``config``, calls
    ``agents.training.imitation.warm_start(model, env_id, seed=seed, env_kwargs=env_kwargs,
    check_stop=check_stop, checkpoint=warm_start_file, progress=progress, label=label,
    **settings)``
    once the model is built, before any training; a run resumed from its
    ``checkpoints/latest.zip`` never calls it again.

    :param config: the run's settings (:func:`run_config`)
    :param env: the VecEnv it trains on (:func:`make_training_env`)
    :param tensorboard_log: the folder for TensorBoard logs, or None
    :param check_stop: called between the warm start's steps; raises to stop it
        (:meth:`agents.interrupts.StopRequests.raise_if_requested`)
    :param warm_start_file: the warm start's progress file (:func:`warm_start_checkpoint`):
        saved there when ``check_stop`` stops it, continued from there when it exists
    :param progress: let the warm start print its stages and progress bars
    :param label: put before each of those (several runs writing to one output)
    """
    algo = config.get("algo", "ppo")
    kwargs = with_schedules(copy.deepcopy(config[algo]))  # SB3 adds keys to policy_kwargs
    noise = action_noise(kwargs, int(env.action_space.shape[0]))
    for name in NOISE_SETTINGS:
        kwargs.pop(name, None)
    if noise is not None:
        kwargs["action_noise"] = noise
    policy = policy_class(algo, kwargs.pop("policy", "MlpPolicy"), "policy")
    trained_agent = config.get("trained_agent")
    if trained_agent is not None:
        model = load_trained_agent(pathlib.Path(trained_agent), config, env, kwargs)
        model.tensorboard_log = tensorboard_log
    else:
        model = algorithm_class(algo)(
            policy,
            env,
            seed=config["seed"],
            device="cpu",
            tensorboard_log=tensorboard_log,
            verbose=0,
            **kwargs,
        )
    label_policy(model, config)
    settings = config.get("warm_start")
    if settings is not None and trained_agent is None:
        from agents.training.imitation import warm_start

        warm_start(
            model,
            config["env"],
            seed=config["seed"],
            env_kwargs=dict(config.get("env_kwargs") or {}),
            check_stop=check_stop,
            checkpoint=warm_start_file,
            **{"progress": progress, "label": label, **settings},  # an entry's own settings win
        )
    return model


def check_trained_agent(path: pathlib.Path, config: dict[str, Any]) -> None:
    """Check that the saved model at ``path`` can go on training as the run ``config``
    describes (rl-baselines3-zoo's ``--trained-agent``): a model of the run's algorithm,
    trained on the same kinematic model, with the network the run's ``policy_kwargs`` give
    (if they give one) and the observation and action spaces of the run's env.

    :param path: a model saved by SB3 or sb3-contrib
    :param config: the run's settings (:func:`run_config`)
    :raises ValueError: naming ``path`` when it is missing, not a model, of another
        algorithm, trained on another kinematic model, or its spaces do not fit the env;
        naming the setting when the run's ``policy_kwargs`` are not the saved network's
    """
    import gymnasium as gym
    from stable_baselines3.common.utils import check_for_correct_spaces

    import mobile_envs  # noqa: F401  (registers the ids)
    from agents.harness.policies import first_line, load_policy, trained_model_name

    algo = config.get("algo", "ppo")
    saved = load_policy(path, algo=algo)  # the clear errors for a missing or damaged file
    if trained_model_name(saved) not in (None, gym.spec(config["env"]).kwargs.get("model")):
        raise ValueError(
            f"--trained-agent {path} was trained on {getattr(saved, 'trained_on', None)}, "
            f"another robot than {config['env']}'s"
        )
    wanted = config[algo].get("policy_kwargs")
    if wanted is not None and wanted != saved.policy_kwargs:
        raise ValueError(
            f"policy_kwargs {wanted} are not those of --trained-agent {path} "
            f"({saved.policy_kwargs}): training goes on in the saved network"
        )
    env = gym.make(config["env"], **env_kwargs_for(config))
    try:
        check_for_correct_spaces(env, saved.observation_space, saved.action_space)
    except ValueError as error:
        raise ValueError(f"--trained-agent {path}: {first_line(error)}") from None
    finally:
        env.close()


def load_trained_agent(
    path: pathlib.Path, config: dict[str, Any], env: Any, settings: dict[str, Any]
) -> BaseAlgorithm:
    """The saved model at ``path`` (checked by :func:`check_trained_agent`), to train on
    ``env`` from its weights: the run's own algorithm settings replace the saved ones (a new
    learning rate, batch or number of epochs), its step count starts at 0 and its random
    generators from the run's seed. The network stays the saved one.

    :param path: a model saved by SB3 or sb3-contrib, of the run's algorithm
    :param config: the run's settings (:func:`run_config`)
    :param env: the VecEnv it trains on
    :param settings: the algorithm's keyword arguments, schedules and noise made
    :raises ValueError: as :func:`check_trained_agent`
    """
    check_trained_agent(path, config)
    model = algorithm_class(config.get("algo", "ppo")).load(
        path, env=env, device="cpu", verbose=0, **settings
    )
    model.num_timesteps = 0
    model.set_random_seed(config["seed"])
    return model


def train_run(
    folder: pathlib.Path,
    config: dict[str, Any] | None = None,
    *,
    callbacks: Sequence[BaseCallback] = (),
    threads: int = 1,
    requests: StopRequests | None = None,
    label: str | None = None,
) -> BaseAlgorithm:
    """Train the run in ``folder`` to ``config["timesteps"]`` steps and return the model.

    A folder that already holds ``checkpoints/latest.zip`` continues from it with its own
    ``config.yml`` (as ``train.py --resume`` does), and its replay buffer for the off-policy
    algorithms; one stopped during its warm start (``config.yml`` and
    :func:`warm_start_checkpoint`) builds the model again and goes on with the warm start;
    otherwise ``config`` starts a new run there. The checkpoint and
    ``final_model.zip`` are saved at the end, also when a callback stops training early or an
    exception (Ctrl-C included) interrupts it. Each call appends the machine to
    ``machine.yml``.

    :param folder: the run folder
    :param config: the settings of a new run (:func:`run_config`); ignored when resuming
    :param callbacks: more SB3 callbacks, after the checkpoint callback
    :param threads: torch threads; 1, since on 2 cores 2 threads made PPO ~15x slower
    :param requests: stop signals to honour: the warm start and training stop at their next
        step after one, and :class:`~agents.interrupts.Interrupted` is raised once the
        checkpoint is saved
    :param label: show the warm start's stages and progress bars, this before each (several
        runs writing to one output); None: the warm start shows nothing
    :raises ValueError: when there is neither a checkpoint nor a config
    """
    import torch
    import yaml

    from agents.training.checkpoints import (
        AtomicCheckpointCallback,
        StopOnRequest,
        load_checkpoint,
        save_atomically,
        save_checkpoint,
    )
    from agents.training.machine import record_machine

    torch.set_num_threads(threads)
    checkpoint = folder / "checkpoints" / "latest.zip"
    resuming = checkpoint.is_file()
    if resuming or warm_start_checkpoint(folder).is_file():
        config = yaml.safe_load((folder / "config.yml").read_text())
    elif config is None:
        raise ValueError(f"{folder} holds no checkpoint to continue, and no config was given")
    else:
        write_config(folder, config)
    assert config is not None
    env = make_training_env(config)
    if resuming:
        model = load_checkpoint(folder, env, algo=config.get("algo", "ppo"), config=config)
    else:
        check_stop = None if requests is None else requests.raise_if_requested
        model = build_model(
            config,
            env,
            check_stop=check_stop,
            warm_start_file=warm_start_checkpoint(folder),
            progress=label is not None,
            label=label or "",
        )
    record_machine(folder, model.num_timesteps)
    remaining = config["timesteps"] - model.num_timesteps
    every_step = [AtomicCheckpointCallback(folder, config["checkpoint_freq"]), *callbacks]
    try:
        if remaining > 0:
            model.learn(
                remaining,
                callback=every_step if requests is None else StopOnRequest(requests, every_step),
                reset_num_timesteps=not resuming,
            )
        if requests is not None:
            requests.raise_if_requested()
    finally:
        save_checkpoint(model, folder)
        save_atomically(model, folder / "final_model.zip")
        env.close()
    return model
