"""agents.grid.grid on the local backend: every final policy measured by the harness, the table's
statistics against reference numbers, determinism across processes, a cut-short run that
restarts to the same numbers, and a second command that restores instead of retraining."""

import json
import math
import pathlib

import numpy as np
import pytest

pytest.importorskip("yaml", reason="the grid reads YAML (the train extra)")

import yaml

pytest.importorskip("stable_baselines3", reason="training needs the train extra")
pytest.importorskip("scipy", reason="the grid's statistics need the sweep extra")

from stable_baselines3.common.callbacks import BaseCallback
from tiny_runs import TINY_PPO, grid_flags, same_numbers

from agents.grid.grid import main
from agents.grid.run import parse_seeds, run_one
from agents.grid.table import split_env_id
from agents.harness.evaluate import evaluate
from agents.harness.policies import load_policy
from agents.training.runs import train_run

#: t_{0.975, 1}: the two-sided 95% Student-t quantile for 2 seeds (statistical tables).
T_975_ONE_DOF = 12.706205


@pytest.fixture(scope="module")
def local_grid(tmp_path_factory):
    """A grid of 2 seeds run by 2 local processes: (its folder, its flags)."""
    folder = tmp_path_factory.mktemp("grid")
    hyperparams = folder / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    flags = grid_flags(folder / "out", hyperparams, "--workers", "2")
    assert main(flags) == 0
    return folder / "out", flags


def records(output):
    return {
        record["run"]: record for record in json.loads((output / "grid.json").read_text())["runs"]
    }


def test_seed_lists_parse_and_bad_ones_are_named():
    assert parse_seeds("0-3,7") == [0, 1, 2, 3, 7]
    assert parse_seeds("5") == [5]
    for text, message in (("3-1", "backwards"), ("a", "expected"), ("1,0-2", "repeats")):
        with pytest.raises(ValueError, match=message):
            parse_seeds(text)
    with pytest.raises(ValueError, match="MODEL-PATHS-v0"):
        split_env_id("mobile_envs/PathFollowing-v0")


def test_every_run_is_its_final_policy_measured_by_the_harness(local_grid):
    output, _ = local_grid
    runs = records(output)
    assert sorted(runs) == ["DiffDrive-Random-v0_ppo_seed0", "DiffDrive-Random-v0_ppo_seed1"]
    for name, record in runs.items():
        folder = output / "runs" / name
        config = yaml.safe_load((folder / "config.yml").read_text())
        policy = load_policy(folder / "final_model.zip")
        assert config["seed"] == record["spec"]["seed"] and policy.num_timesteps >= 512
        for env_id in ("mobile_envs/DiffDrive-Random-v0", "mobile_envs/DiffDrive-Lines-v0"):
            summary = evaluate(policy, env_id, 2, seed=1_000_000).summary
            same_numbers(record["results"][env_id], summary)


def test_the_table_gives_the_mean_over_seeds_with_its_t_interval(local_grid):
    output, _ = local_grid
    runs = sorted(records(output).values(), key=lambda record: record["run"])
    rows = json.loads((output / "grid.json").read_text())["rows"]
    by_paths = {row["path set"]: row for row in rows}
    assert set(by_paths) == {"Random", "Lines", "all"}
    scores = [run["results"]["mobile_envs/DiffDrive-Lines-v0"]["mean_abs_cte"] for run in runs]
    lines = by_paths["Lines"]["mean_abs_cte"]
    assert lines["mean"] == pytest.approx(np.mean(scores))
    assert lines["ci95"] == pytest.approx(T_975_ONE_DOF * np.std(scores, ddof=1) / math.sqrt(2))
    # Over all path sets the samples are the seeds, each the mean of its path sets.
    per_seed = [
        np.mean([summary["mean_abs_cte"] for summary in run["results"].values()]) for run in runs
    ]
    assert by_paths["all"]["mean_abs_cte"]["mean"] == pytest.approx(np.mean(per_seed))
    assert by_paths["all"]["runs"] == 2
    table = (output / "grid.md").read_text()
    assert "| DiffDrive | Lines | ppo | 2 | " in table
    assert f"{lines['mean']:.4f} ± {lines['ci95']:.4f}" in table
    assert (output / "iqm.png").read_bytes()[:4] == b"\x89PNG"


def test_a_run_gives_the_same_numbers_bit_for_bit_in_this_process(local_grid, tmp_path):
    output, _ = local_grid
    record = records(output)["DiffDrive-Random-v0_ppo_seed0"]
    again = run_one(spec_of(record), str(tmp_path))
    same_numbers(again["results"], record["results"])


def spec_of(record):
    from agents.grid.run import RunSpec

    fields = dict(record["spec"])
    fields["eval_envs"] = tuple(fields["eval_envs"])
    return RunSpec(**fields)


class StopAt(BaseCallback):
    def __init__(self, steps):
        super().__init__()
        self.steps = steps

    def _on_step(self):
        return self.num_timesteps < self.steps


def test_a_run_cut_short_restarts_from_zero_to_the_same_numbers(local_grid, tmp_path):
    output, _ = local_grid
    record = records(output)["DiffDrive-Random-v0_ppo_seed1"]
    spec = spec_of(record)
    folder = tmp_path / "runs" / spec.name
    from agents.grid.run import run_config_of

    train_run(folder, run_config_of(spec), callbacks=[StopAt(256)])  # as if interrupted
    assert load_policy(folder / "checkpoints" / "latest.zip").num_timesteps == 256
    same_numbers(run_one(spec, str(tmp_path))["results"], record["results"])


def test_a_worker_s_signal_inside_a_kernel_stops_its_run_and_the_next_attempt_finishes_it(
    local_grid, tmp_path
):
    import signal
    import sys

    from test_interrupts import signal_inside_numba

    from agents.interrupts import Interrupted

    output, _ = local_grid
    record = records(output)["DiffDrive-Random-v0_ppo_seed1"]
    spec = spec_of(record)
    sys.setprofile(signal_inside_numba(signal.SIGTERM))
    try:
        with pytest.raises(Interrupted):
            run_one(spec, str(tmp_path))
    finally:
        sys.setprofile(None)
    folder = tmp_path / "runs" / spec.name
    assert (folder / "checkpoints" / "latest.zip").is_file()
    assert not (folder / "evaluation.json").exists()
    same_numbers(run_one(spec, str(tmp_path))["results"], record["results"])


def test_running_the_command_again_restores_instead_of_retraining(local_grid):
    output, flags = local_grid
    before = (output / "grid.json").read_text()
    assert main(flags) == 0
    assert (output / "grid.json").read_text() == before
    for name in records(output):
        assert len((output / "runs" / name / "attempts.log").read_text().splitlines()) == 1


def test_bad_grids_exit_2_with_one_line(local_grid, tmp_path, capsys):
    output, flags = local_grid
    hyperparams = pathlib.Path(flags[flags.index("--hyperparams") + 1])
    assert main(grid_flags(tmp_path, hyperparams, "--seeds", "2-1")) == 2
    assert main(grid_flags(tmp_path, hyperparams, "--eval-paths", "Moon")) == 2
    other = grid_flags(output, hyperparams, "--episodes", "3")
    assert main(other) == 2  # the folders hold runs of other settings
    errors = capsys.readouterr().err
    assert "--seeds: range '2-1' runs backwards" in errors
    assert "no env mobile_envs/DiffDrive-Moon-v0" in errors
    assert "holds a run of other settings" in errors
