"""agents.training.export / train.py export: onnxruntime gives the actions SB3's predict gives.

Truth: ``model.predict(observations, deterministic=True)``, SB3's own path from observation to
action, on 1000 observations the env produced while the policy drove it (random paths and
mazes, stochastic actions so the states spread), for the shipped PPO policy and tiny PPO
(MlpPolicy and SpeedFloorPolicy), SAC, TD3 and TQC models trained a few hundred steps.
"""

import pathlib

import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="export needs the train extra")
pytest.importorskip("onnxruntime", reason="running ONNX needs the export extra")
pytest.importorskip("onnx", reason="checking the graph needs the export extra")

import onnx
import onnxruntime

import train
from agents.harness.policies import load_policy
from agents.training.export import INPUT_NAME, OUTPUT_NAME, export_onnx
from agents.training.runs import build_model, make_training_env
from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

ROOT = pathlib.Path(__file__).resolve().parents[1]
ENV_ID = "mobile_envs/DiffDrive-Random-v0"
TINY_OFF_POLICY = {
    "learning_starts": 100,
    "buffer_size": 5_000,
    "batch_size": 32,
    "gradient_steps": 1,
    "policy_kwargs": {"net_arch": [32, 32]},
}


def real_observations(model, count=1000, robots=20, seed=123):
    """``count`` observations of ``robots`` robots that the policy drives, stochastically, in
    the env it was trained on."""
    env = PathFollowingSB3VecEnv(getattr(model, "trained_on", ENV_ID), robots, seed=seed)
    observations = [env.reset()]
    while len(observations) * robots < count:
        actions, _ = model.predict(observations[-1], deterministic=False)
        observations.append(env.step(actions)[0])
    env.close()
    return np.concatenate(observations)[:count].astype(np.float32)


def tiny_model(algo):
    """A model of ``algo`` trained 400 steps on 4 robots."""
    config = {
        "env": ENV_ID,
        "algo": algo,
        "seed": 0,
        "n_envs": 4,
        "env_kwargs": {},
        "vec_env": "native",
        algo: dict(TINY_OFF_POLICY),
    }
    if algo.startswith("ppo"):
        config["algo"] = "ppo"
        config["ppo"] = {"n_steps": 64, "batch_size": 64, "policy_kwargs": {"net_arch": [32, 32]}}
    if algo == "ppo-speed-floor":  # a barely trained mean speed: many commands are floored
        config["ppo"]["policy"] = "agents.training.speed_floor.SpeedFloorPolicy"
        config["ppo"]["policy_kwargs"].update(speed_floor=0.3, previous_speed_observation=27)
    env = make_training_env(config)
    model = build_model(config, env)
    model.learn(400)
    env.close()
    return model


@pytest.fixture(
    scope="module", params=["ppo-shipped", "ppo", "ppo-speed-floor", "sac", "td3", "tqc"]
)
def model(request):
    if request.param == "ppo-shipped":
        return load_policy(ROOT / "models" / "diffdrive_ppo.zip")
    return tiny_model(request.param)


def onnx_actions(path, observations):
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    session = onnxruntime.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    return session.run([OUTPUT_NAME], {INPUT_NAME: observations})[0]


def test_onnxruntime_gives_the_actions_of_deterministic_predict(model, tmp_path):
    path = export_onnx(model, tmp_path / "policy.onnx")
    onnx.checker.check_model(onnx.load(str(path)))
    observations = real_observations(model)
    expected, _ = model.predict(observations, deterministic=True)
    actions = onnx_actions(path, observations)
    assert actions.shape == expected.shape == (1000, 2) and actions.dtype == np.float32
    np.testing.assert_allclose(actions, expected, rtol=0, atol=1e-5)
    # The comparison is not of saturated actions only: hundreds lie inside the bounds.
    inside = np.mean(np.abs(expected) < 0.999)
    assert inside > 0.1, inside
    floor = getattr(model.policy, "speed_floor", 0.0)
    if floor > 0:  # and where the speed was floored, both ways
        floored = np.abs(expected[:, 0]) == np.float32(floor)
        assert np.any(expected[floored, 0] > 0) and np.any(expected[floored, 0] < 0)


def test_the_batch_axis_is_dynamic(model, tmp_path):
    path = export_onnx(model, tmp_path / "policy.onnx")
    observations = real_observations(model, count=40)
    batched = onnx_actions(path, observations)
    one_by_one = np.concatenate([onnx_actions(path, row[None]) for row in observations])
    np.testing.assert_allclose(one_by_one, batched, rtol=0, atol=1e-6)
    single, _ = model.predict(observations[0], deterministic=True)  # one unbatched observation
    np.testing.assert_allclose(batched[0], single, rtol=0, atol=1e-5)


def test_train_py_export_writes_the_graph(tmp_path, capsys):
    source = ROOT / "models" / "bicycle_ppo.zip"
    output = tmp_path / "deploy" / "bicycle.onnx"
    assert train.main(["export", "--model", str(source), "--output", str(output)]) == 0
    assert str(output) in capsys.readouterr().out
    model = load_policy(source)
    observations = real_observations(model, count=100)
    expected, _ = model.predict(observations, deterministic=True)
    np.testing.assert_allclose(onnx_actions(output, observations), expected, rtol=0, atol=1e-5)
    assert [path.name for path in output.parent.iterdir()] == ["bicycle.onnx"]  # no .partial


def test_export_replaces_neither_the_model_nor_what_is_not_a_regular_file(tmp_path, capsys):
    """Issue 30: --output mine.zip with --model mine.zip replaced the model with the graph; a
    symbolic link, a FIFO or a device at --output became a regular file; an existing file was
    replaced unasked."""
    import os

    model = tmp_path / "mine.zip"
    model.write_bytes((ROOT / "models" / "bicycle_ppo.zip").read_bytes())
    original = model.read_bytes()
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    link = tmp_path / "link.onnx"
    link.symlink_to(model)
    existing = tmp_path / "old.onnx"
    existing.write_bytes(b"an older graph")
    refusals = {
        model: "is the model being exported",
        fifo: "not a regular file",
        link: "symbolic link",
        pathlib.Path("/dev/null"): "not a regular file",
        existing: "exists",
    }
    for output, reason in refusals.items():
        assert train.main(["export", "--model", str(model), "--output", str(output)]) == 2
        error = capsys.readouterr().err
        assert f"--output: {output}" in error and reason in error, error
    assert model.read_bytes() == original and link.is_symlink() and fifo.is_fifo()
    assert existing.read_bytes() == b"an older graph"
    force = ["--force"]
    assert train.main(["export", "--model", str(model), "--output", str(model), *force]) == 2
    assert model.read_bytes() == original
    assert train.main(["export", "--model", str(model), "--output", str(existing), *force]) == 0
    assert onnx.load(str(existing)).graph.input[0].name == INPUT_NAME
    with pytest.raises(ValueError, match="exists"):
        export_onnx(load_policy(model), existing)  # the library refuses too, unless asked
    assert sorted(path.name for path in tmp_path.iterdir()) == sorted(
        ["mine.zip", "pipe", "link.onnx", "old.onnx"]
    )
