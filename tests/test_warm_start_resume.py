"""A stop signal during the warm start keeps it like a checkpoint (issue 31, item 10): train.py
saves the warm start's progress beside config.yml, says how to go on, and ``--resume`` ends
with the weights of a run that was never stopped, bit for bit; train_run (the sweep's and the
grid's trainer) resumes such a folder too."""

import signal

import pytest

pytest.importorskip("stable_baselines3", reason="training needs the train extra")

import torch
import yaml

import train
from agents.harness.policies import load_policy
from agents.interrupts import StopRequests

WARM_START = {"robots": 2, "steps": 300, "epochs": 2, "batch_size": 128}
#: A tiny PPO entry with a warm start, in the zoo's callback form hyperparams/ppo.yml uses.
ENTRY = {
    "n_steps": 64,
    "batch_size": 64,
    "policy_kwargs": {"net_arch": [16, 16]},
    "callback": [{"agents.training.imitation.WarmStartCallback": WARM_START}],
}
ENV_ID = "mobile_envs/DiffDrive-Lines-v0"
FLAGS = ["--env", ENV_ID, "--n-envs", "2", "--timesteps", "256", "--eval-freq", "0"]


@pytest.fixture
def hyperparams(tmp_path):
    path = tmp_path / "ppo.yml"
    path.write_text(yaml.safe_dump({"default": ENTRY}))
    return path


def weights(path):
    return torch.nn.utils.parameters_to_vector(load_policy(path).policy.parameters())


def sigterm_at_poll(monkeypatch, at: int) -> None:
    """SIGTERM arrives just before train.py's ``at``-th poll of its stop requests."""
    original = StopRequests.raise_if_requested
    polls = 0

    def poll(self):
        nonlocal polls
        polls += 1
        if polls == at:
            signal.raise_signal(signal.SIGTERM)
        original(self)

    monkeypatch.setattr(StopRequests, "raise_if_requested", poll)


@pytest.mark.parametrize("at", [50, 301 + 3], ids=["recording", "cloning"])
def test_sigterm_during_the_warm_start_saves_it_and_resume_ends_where_an_unstopped_run_does(
    at, hyperparams, tmp_path, monkeypatch, capsys
):
    whole = tmp_path / "whole"
    common = [*FLAGS, "--hyperparams", str(hyperparams), "--no-progress"]
    assert train.main([*common, "--output", str(whole)]) == 0
    config = yaml.safe_load((whole / "config.yml").read_text())
    assert config["warm_start"] == WARM_START and "callback" not in config["ppo"]

    stopped = tmp_path / "stopped"
    with monkeypatch.context() as patch:
        sigterm_at_poll(patch, at)
        assert train.main([*common, "--output", str(stopped)]) == 128 + signal.SIGTERM
    out = capsys.readouterr().out
    assert "during the warm start; saved its progress in" in out
    assert f"--resume {stopped}" in out
    assert (stopped / "config.yml").is_file()
    assert (stopped / "checkpoints" / "warm_start.pkl").is_file()
    assert not (stopped / "checkpoints" / "latest.zip").exists()
    # A new run into that folder is refused: it holds a run to resume.
    assert train.main([*common, "--output", str(stopped)]) == train.EXIT_USAGE
    assert "--resume" in capsys.readouterr().err

    assert train.main(["--resume", str(stopped), "--no-progress"]) == 0
    assert torch.equal(weights(stopped / "final_model.zip"), weights(whole / "final_model.zip"))


def test_train_run_resumes_a_folder_stopped_during_its_warm_start(hyperparams, tmp_path):
    from agents.interrupts import Interrupted
    from agents.training.runs import run_config, train_run

    config = run_config(ENV_ID, hyperparams, seed=2, timesteps=128, n_envs=2)
    assert config["warm_start"] == WARM_START
    whole = train_run(tmp_path / "whole", config)

    class StopAtTheTenthPoll(StopRequests):
        polls = 0

        def raise_if_requested(self):
            self.polls += 1
            if self.polls == 10:
                self.signum = signal.SIGTERM
            super().raise_if_requested()

    requests = StopAtTheTenthPoll()
    folder = tmp_path / "stopped"
    with pytest.raises(Interrupted):
        train_run(folder, config, requests=requests)
    assert (folder / "checkpoints" / "warm_start.pkl").is_file()
    resumed = train_run(folder)
    assert torch.equal(
        torch.nn.utils.parameters_to_vector(resumed.policy.parameters()),
        torch.nn.utils.parameters_to_vector(whole.policy.parameters()),
    )
