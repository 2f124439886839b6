"""The clients users already run, as README's "Use with other libraries" runs them: the
``module:id`` form in a fresh process (CleanRL's make_env), Gymnasium's wrappers, SB3's
VecEnv wrappers over the adapter, and rl-zoo3's command lines."""

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids for the in-process tests)

REPO = Path(__file__).resolve().parent.parent
ENV_ID = "mobile_envs/DiffDrive-Segments-v0"


def run_python(args: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    """A fresh Python process on one torch thread, its output kept for the failure message."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SDL_VIDEODRIVER": "dummy"}
    result = subprocess.run(
        [sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result


# CleanRL's ppo_continuous_action.py env setup and episode logging, as on its master branch,
# with the env id in the module:id form. Its make_env is docs/recipes' (edit 1 of
# docs/integrations.md: Gymnasium 1.x's TransformObservation needs the observation space;
# CleanRL's two-argument call raises TypeError on any env).
CLEANRL_SCRIPT = """
import runpy, sys
import gymnasium as gym
import numpy as np

make_env = runpy.run_path(sys.argv[1])["make_env"]  # its definitions only, not its __main__
envs = gym.vector.SyncVectorEnv(
    [make_env("mobile_envs:mobile_envs/DiffDrive-Segments-v0", i, True, "run", 0.99)
     for i in range(2)],
    autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
)
assert "mobile_envs" in sys.modules  # imported by gym.make through the module: prefix
obs, _ = envs.reset(seed=1)
envs.action_space.seed(1)
lengths = []
for _ in range(400):
    obs, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
    assert np.all(np.abs(obs) <= 10)
    if "final_info" in infos:
        episodes_over = np.nonzero(infos["final_info"]["_episode"])[0]
        lengths += infos["final_info"]["episode"]["l"][episodes_over].tolist()
envs.close()
print("episodes", len(lengths), "mean length", np.mean(lengths))
"""


def test_cleanrl_make_env_finds_the_ids_through_the_module_prefix(tmp_path):
    pytest.importorskip("moviepy", reason="recording a video needs moviepy (the render extra)")
    recipe = REPO / "docs" / "recipes" / "cleanrl_ppo_continuous_action.py"
    result = run_python(["-c", CLEANRL_SCRIPT, str(recipe)], cwd=tmp_path)
    episodes = int(result.stdout.split()[1])
    assert episodes >= 2
    assert list((tmp_path / "videos" / "run").glob("*.mp4"))


def test_the_bare_id_needs_the_import_and_says_so(tmp_path):
    script = (
        "import gymnasium as gym\n"
        "try:\n"
        "    gym.make('mobile_envs/DiffDrive-Segments-v0')\n"
        "except gym.error.NamespaceNotFound:\n"
        "    print('not found')\n"
        "import mobile_envs\n"
        "print(type(gym.make('mobile_envs/DiffDrive-Segments-v0').unwrapped).__name__)\n"
        "print(type(gym.make_vec('mobile_envs:mobile_envs/Bicycle-Lines-v0', 3)).__name__)\n"
    )
    lines = run_python(["-c", script], cwd=tmp_path).stdout.split()
    assert lines == ["not", "found", "PathFollowingEnv", "PathFollowingVectorEnv"]


def test_gymnasium_episode_statistics_match_the_rewards_the_env_gave():
    env = gym.wrappers.RecordEpisodeStatistics(
        gym.wrappers.FrameStackObservation(gym.make(ENV_ID, step_limit=60), 4)
    )
    observation, _ = env.reset(seed=2)
    assert observation.shape == (4, *env.unwrapped.observation_space.shape)
    rng = np.random.default_rng(0)
    total, steps = 0.0, 0
    while True:
        observation, reward, terminated, truncated, info = env.step(
            rng.uniform(-0.2, 1.0, 2).astype(np.float32)
        )
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert info["episode"]["l"] == steps == env.unwrapped.elapsed_steps
    assert info["episode"]["r"] == pytest.approx(total, rel=1e-6)


def test_gymnasium_vector_wrappers_over_the_native_vector_env():
    from gymnasium.wrappers.vector import NormalizeObservation, RecordEpisodeStatistics

    count = 4
    envs = RecordEpisodeStatistics(
        NormalizeObservation(gym.make_vec(ENV_ID, num_envs=count, step_limit=30))
    )
    envs.reset(seed=0)
    returns, lengths = np.zeros(count), np.zeros(count, int)
    rng = np.random.default_rng(1)
    ended = np.zeros(count, bool)
    checked = 0
    for _ in range(70):
        _, rewards, terminated, truncated, infos = envs.step(
            rng.uniform(0.0, 0.5, (count, 2)).astype(np.float32)
        )
        # Next-step autoreset: the step after an ending is the reset, with reward 0.
        returns[~ended] += rewards[~ended]
        lengths[~ended] += 1
        if "episode" in infos:
            done = infos["_episode"]
            np.testing.assert_allclose(infos["episode"]["r"][done], returns[done], rtol=1e-6)
            np.testing.assert_array_equal(infos["episode"]["l"][done], lengths[done])
            checked += done.sum()
        returns[ended] = 0.0
        lengths[ended] = 0
        ended = terminated | truncated
    assert checked >= 2 * count


def test_sb3_vec_wrappers_over_the_adapter():
    pytest.importorskip("stable_baselines3", reason="the adapter needs the train extra")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecFrameStack, VecMonitor, VecNormalize

    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    count, stack = 3, 3
    raw = PathFollowingSB3VecEnv(ENV_ID, count, seed=4, step_limit=25)
    normalize = VecNormalize(
        VecMonitor(PathFollowingSB3VecEnv(ENV_ID, count, seed=4, step_limit=25))
    )
    envs = VecFrameStack(normalize, n_stack=stack)
    size = raw.observation_space.shape[0]
    assert envs.observation_space.shape == (stack * size,)
    seen = [raw.reset()]
    stacked = envs.reset()
    returns = np.zeros(count)
    episodes = 0
    rng = np.random.default_rng(2)
    for _ in range(60):
        actions = rng.uniform(-0.3, 1.0, (count, 2)).astype(np.float32)
        raw_obs, raw_rewards, raw_dones, _ = raw.step(actions)
        previous = stacked
        stacked, _, dones, infos = envs.step(actions)
        seen.append(raw_obs)
        np.testing.assert_array_equal(dones, raw_dones)
        # The unwrapped twin's observations are what VecNormalize saw...
        np.testing.assert_array_equal(normalize.get_original_obs(), raw_obs)
        # ...the newest frame is them normalized, the one before is the previous newest.
        np.testing.assert_allclose(
            stacked[:, -size:], normalize.normalize_obs(raw_obs), rtol=1e-5, atol=1e-6
        )
        live = ~dones
        np.testing.assert_array_equal(stacked[live, -2 * size : -size], previous[live, -size:])
        returns += raw_rewards
        for index in np.flatnonzero(dones):
            assert infos[index]["episode"]["r"] == pytest.approx(returns[index], abs=1e-5)
            returns[index] = 0.0
            episodes += 1
    assert episodes >= count
    # VecNormalize's running statistics are those of every observation it was given.
    observations = np.concatenate(seen)
    np.testing.assert_allclose(normalize.obs_rms.mean, observations.mean(axis=0), atol=1e-5)
    np.testing.assert_allclose(normalize.obs_rms.var, observations.var(axis=0), atol=1e-4)
    PPO("MlpPolicy", envs, n_steps=32, batch_size=48, n_epochs=1, device="cpu").learn(96)


@pytest.fixture(scope="module")
def zoo_run(tmp_path_factory):
    """One tiny rl-zoo3 training run, as README's command gives it, at 2048 steps."""
    pytest.importorskip("rl_zoo3", reason="rl-zoo3 is the zoo extra")
    folder = tmp_path_factory.mktemp("zoo")
    command = [
        "-m", "rl_zoo3.train", "--algo", "ppo", "--env", ENV_ID,
        "--gym-packages", "mobile_envs", "--conf-file", str(REPO / "hyperparams" / "ppo.yml"),
        "-n", "2048", "--num-threads", "1", "--seed", "0", "--log-folder", str(folder),
        "--hyperparams", "n_envs:2", "n_steps:256", "batch_size:256", "n_epochs:1",
    ]  # fmt: skip
    run_python(command, cwd=folder)
    return folder


def test_rl_zoo3_trains_on_an_id_with_gym_packages(zoo_run):
    run = zoo_run / "ppo" / "mobile_envs-DiffDrive-Segments-v0_1"
    assert (run / "mobile_envs-DiffDrive-Segments-v0.zip").is_file()
    episodes = 0
    for monitor in run.glob("*.monitor.csv"):
        rows = monitor.read_text().splitlines()[2:]  # a JSON line, then the header
        lengths = [int(row.split(",")[1]) for row in rows]
        assert sum(lengths) <= 1024  # each of the two envs took 1024 of the 2048 steps
        episodes += len(lengths)
    assert episodes >= 2


def test_rl_zoo3_enjoy_and_record_video_load_the_trained_model(zoo_run):
    enjoy = [
        "-m", "rl_zoo3.enjoy", "--algo", "ppo", "--env", ENV_ID,
        "--gym-packages", "mobile_envs", "-f", str(zoo_run), "-n", "50", "--no-render",
    ]  # fmt: skip
    run_python(enjoy, cwd=zoo_run)
    # record_video has no --gym-packages: import the package, then run the module.
    record = (
        "import mobile_envs, runpy, sys; sys.argv = ['record_video', '--algo', 'ppo', "
        f"'--env', '{ENV_ID}', '-f', '{zoo_run}', '-n', '20', '-o', '{zoo_run}/videos']; "
        "runpy.run_module('rl_zoo3.record_video', run_name='__main__')"
    )
    run_python(["-c", record], cwd=zoo_run)
    assert list((zoo_run / "videos").glob("*.mp4"))


# ------------------------------------------------------------------ rl-zoo3 and the warm start

ZOO_OWN_KEYS = ("n_timesteps", "n_envs", "env_kwargs", "callback", "normalize", "env_wrapper")


@pytest.mark.parametrize("name", ["ppo.yml", "ppo_randomized.yml"])
def test_every_entry_of_the_ppo_hyperparams_is_rl_zoo3_style(name):
    """What rl-zoo3 hands PPO (each entry less the keys the zoo takes itself) is only PPO's
    settings, and the warm start is a zoo callback that builds; train.py reads the same
    callback as its run's warm start."""
    pytest.importorskip("rl_zoo3", reason="rl-zoo3 is the zoo extra")
    import yaml
    from rl_zoo3.utils import get_callback_list, get_class_by_name

    from agents.training.imitation import WarmStartCallback
    from agents.training.runs import check_algorithm_settings, policy_class, pop_warm_start

    table = yaml.safe_load((REPO / "hyperparams" / name).read_text())
    random_ids = [key for key in table if key.endswith("-Random-v0")]
    assert len(random_ids) == 4
    for env_id, entry in table.items():
        settings = {key: value for key, value in entry.items() if key not in ZOO_OWN_KEYS}
        check_algorithm_settings("ppo", settings, f"{name}: {env_id}")
        policy = settings.get("policy", "MlpPolicy")
        if "." in policy:  # the zoo imports a policy named by its path, as train.py does
            assert get_class_by_name(policy) is policy_class("ppo", policy, name)
        callbacks = get_callback_list(dict(entry))
        warm_start = pop_warm_start(dict(entry), name)
        if env_id in random_ids or env_id == "warm_started":  # the anchor the ids merge
            (callback,) = callbacks
            assert isinstance(callback, WarmStartCallback)
            assert warm_start["teacher"] == "regulated_pure_pursuit"
            assert callback.settings == {"progress": True, **warm_start}
        else:
            assert callbacks == [] and warm_start is None


def test_rl_zoo3_trains_a_random_id_with_the_shipped_hyperparams_and_its_warm_start(tmp_path):
    """hyperparams/ppo.yml on DiffDrive-Random (its env kwargs and warm start), a few hundred
    steps; the warm start's size is cut on the command line, as a zoo user would."""
    pytest.importorskip("rl_zoo3", reason="rl-zoo3 is the zoo extra")
    env_id = "mobile_envs/DiffDrive-Random-v0"
    small = "{'agents.training.imitation.WarmStartCallback': dict(robots=4, steps=300, epochs=2)}"
    command = [
        "-m", "rl_zoo3.train", "--algo", "ppo", "--env", env_id, "--gym-packages", "mobile_envs",
        "--conf-file", str(REPO / "hyperparams" / "ppo.yml"), "-n", "256", "--num-threads", "1",
        "--seed", "0", "--log-folder", str(tmp_path),
        "--hyperparams", "n_envs:2", "n_steps:128", "batch_size:128", "n_epochs:1",
        f"callback:[{small}]",
    ]  # fmt: skip
    result = run_python(command, cwd=tmp_path)
    assert f"warm start: regulated_pure_pursuit drives 4 robots of {env_id}" in result.stdout
    assert "warm start: done, action mse" in result.stdout
    run = tmp_path / "ppo" / "mobile_envs-DiffDrive-Random-v0_1"
    assert (run / "mobile_envs-DiffDrive-Random-v0.zip").is_file()
    saved = (run / "mobile_envs-DiffDrive-Random-v0" / "config.yml").read_text()
    assert "peak_cross_track" in saved  # the entry's env kwargs reached the zoo's envs


# ------------------------------------------------------------------ docs/integrations.md

DOCS = REPO / "docs"
RECIPES = DOCS / "recipes"
MODES = ("NextStep", "SameStep", "Disabled")


def wrapper_claims() -> list[tuple[str, str, bool]]:
    """(wrapper, autoreset mode, takes it) for every wrapper the docs' table names."""
    import re

    text = (DOCS / "integrations.md").read_text()
    table = text[text.index("| vector wrapper |") :].split("\n\n")[0].splitlines()[2:]
    claims = []
    for row in table:
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        for name in re.findall(r"`(\w+)`", cells[0]):
            takes = [cell == "yes" for cell in cells[1:]]
            claims += [(name, mode, yes) for mode, yes in zip(MODES, takes, strict=True)]
    return claims


def make_wrapped(name: str, mode: str, count: int = 3):
    from gymnasium.wrappers import vector

    envs = gym.make_vec(ENV_ID, num_envs=count, autoreset_mode=mode, step_limit=15)
    arguments = {
        "TransformObservation": (lambda obs: 2 * obs,),
        "DtypeObservation": (np.float64,),
        "ClipReward": (-1.0, 1.0),
        "RescaleAction": (-2.0, 2.0),
    }
    return getattr(vector, name)(envs, *arguments.get(name, ()))


@pytest.mark.parametrize(("name", "mode", "takes"), wrapper_claims())
def test_the_vector_wrappers_take_the_autoreset_modes_the_docs_say(name, mode, takes):
    if not takes:
        with pytest.raises(ValueError, match="autoreset_mode"):
            make_wrapped(name, mode)
        return
    envs = make_wrapped(name, mode)
    envs.reset(seed=0)
    envs.action_space.seed(0)
    ended_any = False
    for _ in range(40):
        _, _, terminated, truncated, _ = envs.step(envs.action_space.sample())
        ended = terminated | truncated
        ended_any |= ended.any()
        if mode == "Disabled" and ended.any():
            envs.reset(options={"reset_mask": ended})
    assert ended_any  # the wrappers met episode ends in this mode


@pytest.mark.parametrize("mode", MODES)
def test_record_episode_statistics_counts_the_returns_in_every_mode(mode):
    from gymnasium.wrappers.vector import RecordEpisodeStatistics

    count = 3
    envs = RecordEpisodeStatistics(
        gym.make_vec(ENV_ID, num_envs=count, autoreset_mode=mode, step_limit=15)
    )
    envs.reset(seed=1)
    rng = np.random.default_rng(3)
    returns, lengths = np.zeros(count), np.zeros(count, int)
    skip = np.zeros(count, bool)  # next-step mode: the step after an end is the reset
    checked = 0
    for _ in range(60):
        _, rewards, terminated, truncated, infos = envs.step(
            rng.uniform(-0.2, 0.8, (count, 2)).astype(np.float32)
        )
        returns[~skip] += rewards[~skip]
        lengths[~skip] += 1
        ended = terminated | truncated
        if ended.any():
            np.testing.assert_allclose(infos["episode"]["r"][ended], returns[ended], rtol=1e-6)
            np.testing.assert_array_equal(infos["episode"]["l"][ended], lengths[ended])
            checked += ended.sum()
        returns[ended], lengths[ended] = 0.0, 0
        skip = ended if mode == "NextStep" else np.zeros(count, bool)
        if mode == "Disabled" and ended.any():
            envs.reset(options={"reset_mask": ended})
    assert checked >= count


def run_recipe(name: str, monkeypatch, *argv: str) -> dict:
    """Run docs/recipes/NAME in this process as ``__main__``; return its globals."""
    import runpy

    monkeypatch.setattr(sys, "argv", [str(RECIPES / name), *argv])
    return runpy.run_path(str(RECIPES / name), run_name="__main__")


def test_cleanrl_ppo_recipe_logs_every_episode(monkeypatch, capsys):
    """ppo_continuous_action.py's set-up and logging with the docs' edits, in the module:id
    form in a fresh process's way (the recipe never imports mobile_envs)."""
    scope = run_recipe("cleanrl_ppo_continuous_action.py", monkeypatch)
    lengths = [value for tag, value, _ in scope["writer"].scalars if tag.endswith("length")]
    printed = [line for line in capsys.readouterr().out.splitlines() if "episodic_return" in line]
    assert len(lengths) == len(printed) >= 3  # unedited: 0
    # Two envs, 2 x 200 steps each: the logged episodes fit in them.
    assert sum(lengths) <= 2 * 400


def test_cleanrl_sac_recipe_logs_and_stores_the_last_observation_of_truncated_episodes(
    monkeypatch,
):
    """sac_continuous_action.py's set-up, logging and replay-buffer step with the docs'
    edits, on episodes cut at 20 steps: unedited it raised KeyError: 'final_observation' at
    the first truncation."""
    pytest.importorskip("stable_baselines3", reason="CleanRL's SAC stores into SB3's buffer")
    gym.register(
        "mobile_envs_test/ShortLines-v0",
        entry_point="mobile_envs.envs.path_following:PathFollowingEnv",
        kwargs={"model": "diff_drive", "paths": "lines", "step_limit": 20},
    )
    try:
        scope = run_recipe(
            "cleanrl_sac_continuous_action.py", monkeypatch, "mobile_envs_test/ShortLines-v0", "300"
        )
    finally:
        del gym.registry["mobile_envs_test/ShortLines-v0"]
    assert len([tag for tag, _, _ in scope["writer"].scalars if tag.endswith("return")]) >= 5
    buffer = scope["rb"]
    observations, next_observations = buffer.observations[:300], buffer.next_observations[:300]
    # A transition's next observation is the following step's observation, except where the
    # episode ended: there it is the ended episode's last one, not the new episode's first.
    ended = ~(next_observations[:-1] == observations[1:]).all(axis=-1)
    truncated = ended & (buffer.dones[:299] == 0)
    assert truncated.sum() >= 2
    assert (np.abs(next_observations[:-1][truncated]).max(axis=-1) > 0).all()


def test_torchrl_recipe_checks_the_specs_reads_the_info_and_collects(tmp_path):
    pytest.importorskip("torchrl", reason="TorchRL is the torchrl extra")
    result = run_python([str(RECIPES / "torchrl_env.py")], cwd=tmp_path, timeout=600)
    assert "collected 1024 frames from 4 serial envs" in result.stdout
    keys = result.stdout.split("keys:")[1].splitlines()[0]
    for key in ("cross_track_error", "is_success", "pose", "mean_abs_cte", "completed"):
        assert f"'{key}'" in keys


def test_skrl_recipe_trains_ppo_on_the_vector_env(tmp_path):
    pytest.importorskip("skrl", reason="skrl is the skrl extra")
    # 300 vector steps: one rollout of 256 and its update.
    result = run_python([str(RECIPES / "skrl_ppo.py"), "300"], cwd=tmp_path, timeout=600)
    assert "trained skrl's PPO for 300 vector steps of 16 robots" in result.stdout


def test_rllib_recipe_trains_ppo_with_the_module_id_form(tmp_path):
    pytest.importorskip(
        "ray.rllib.algorithms.ppo",
        reason="RLlib (ray[rllib]) pins gymnasium 1.2.2: run docs/recipes/rllib_ppo.py in a "
        "virtual environment of its own (docs/integrations.md)",
    )
    result = run_python([str(RECIPES / "rllib_ppo.py"), "1"], cwd=tmp_path, timeout=600)
    assert "iteration 1: " in result.stdout
