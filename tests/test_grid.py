"""agents.grid.grid on the local backend: every run's selected policy measured by the harness,
the table's statistics against reference numbers, determinism across processes, a cut-short run that
restarts to the same numbers, and a second command that restores instead of retraining."""

import json
import math
import pathlib
import shlex
import shutil

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
from agents.training.checkpoints import SnapshotCallback
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


def test_every_run_is_its_selected_policy_measured_by_the_harness(local_grid):
    """Each row measures the run's best_model.zip, which train.py's evaluations on the
    training env picked (here, 512 steps under --select-every's default of 100,000: the final
    policy, evaluated at the end on 100 episodes)."""
    output, _ = local_grid
    runs = records(output)
    assert sorted(runs) == ["DiffDrive-Random-v0_ppo_seed0", "DiffDrive-Random-v0_ppo_seed1"]
    for name, record in runs.items():
        folder = output / "runs" / name
        config = yaml.safe_load((folder / "config.yml").read_text())
        assert (config["eval_freq"], config["eval_episodes"]) == (100_000, 100)
        policy = load_policy(folder / "best_model.zip")
        final = load_policy(folder / "final_model.zip").policy.state_dict()
        assert all(value.equal(final[key]) for key, value in policy.policy.state_dict().items())
        scored = evaluate(policy, config["env"], 100, seed=10_000, **config["env_kwargs"]).summary
        assert json.loads((folder / "best_model.json").read_text()) == {
            "completion_rate": scored["completion_rate"],
            "mean_abs_cte": scored["mean_abs_cte"],
            "steps": policy.num_timesteps,
        }
        assert config["seed"] == record["spec"]["seed"] and policy.num_timesteps >= 512
        for env_id in ("mobile_envs/DiffDrive-Random-v0", "mobile_envs/DiffDrive-Lines-v0"):
            summary = evaluate(policy, env_id, 2, seed=1_000_000).summary
            same_numbers(record["results"][env_id], summary)


def test_select_every_picks_the_best_evaluated_policy_or_with_0_the_final_one(tmp_path):
    """--select-every 256 over 1024 steps: the row measures the best of the policies at 256,
    512, 768 and 1024 steps on the training env, as train.py keeps it; with 0 no best model is
    kept and the row measures the final policy."""
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))  # 4 robots x 64 steps: 256 a rollout
    rows = {}
    for every in ("256", "0"):
        output = tmp_path / f"every_{every}"
        flags = grid_flags(output, hyperparams, "--seeds", "0", "--timesteps", "1024")
        selection = ["--select-every", every, "--select-episodes", "3"]
        assert main([*flags, *selection]) == 0
        folder = output / "runs" / "DiffDrive-Random-v0_ppo_seed0"
        rows[every] = (records(output)["DiffDrive-Random-v0_ppo_seed0"], folder)
    record, folder = rows["0"]
    assert not (folder / "best_model.zip").exists()
    final = load_policy(folder / "final_model.zip")
    same_numbers(
        record["results"]["mobile_envs/DiffDrive-Lines-v0"],
        evaluate(final, "mobile_envs/DiffDrive-Lines-v0", 2, seed=1_000_000).summary,
    )
    record, folder = rows["256"]
    config = yaml.safe_load((folder / "config.yml").read_text())
    # The same training again, bit for bit, keeping the policy every 256 steps.
    again = tmp_path / "again"
    train_run(again, {**config, "eval_freq": 0}, callbacks=[SnapshotCallback(again, 256)])
    candidates = [
        load_policy(again / "snapshots" / f"steps_{steps:010d}.zip")
        for steps in (256, 512, 768, 1024)
    ]
    scores = [
        evaluate(policy, config["env"], 3, seed=10_000, **config["env_kwargs"]).summary
        for policy in candidates
    ]
    best = max(range(4), key=lambda i: (scores[i]["completion_rate"], -scores[i]["mean_abs_cte"]))
    chosen = load_policy(folder / "best_model.zip")
    same_numbers(
        record["results"]["mobile_envs/DiffDrive-Lines-v0"],
        evaluate(candidates[best], "mobile_envs/DiffDrive-Lines-v0", 2, seed=1_000_000).summary,
    )
    kept = candidates[best].policy.state_dict()
    assert all(value.equal(kept[key]) for key, value in chosen.policy.state_dict().items())


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


def test_a_run_gives_the_same_numbers_bit_for_bit_in_this_process(local_grid, tmp_path, capsys):
    output, _ = local_grid
    record = records(output)["DiffDrive-Random-v0_ppo_seed0"]
    again = run_one(spec_of(record), str(tmp_path))
    same_numbers(again["results"], record["results"])
    # Runs printing side by side name themselves: what it does, then its steps (here at the
    # end only: 512 steps take less than the 30 s between two lines).
    said = capsys.readouterr().out.splitlines()
    assert said[0] == "DiffDrive-Random-v0_ppo_seed0: training to 512 steps"
    assert said[-1].startswith("DiffDrive-Random-v0_ppo_seed0: step 512 of 512 (100%), ")


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


# ---------------------------------------------------------------- issue 30


def test_a_damaged_evaluation_json_is_moved_aside_and_the_run_evaluated_again(
    local_grid, tmp_path, capsys
):
    """Issue 30: {} gave a KeyError, [1,2] a TypeError, an empty file a JSON error naming no
    file, and the whole grid refused to start."""
    output, flags = local_grid
    copy = tmp_path / "grid"
    shutil.copytree(output, copy)
    before = records(output)
    damages = {"DiffDrive-Random-v0_ppo_seed0": "{}", "DiffDrive-Random-v0_ppo_seed1": "[1,2]"}
    for name, text in damages.items():
        (copy / "runs" / name / "evaluation.json").write_text(text)
    assert main([*flags[: flags.index("--output")], "--output", str(copy)]) == 0
    said = capsys.readouterr().out
    for name, text in damages.items():
        folder = copy / "runs" / name
        assert f"{folder / 'evaluation.json'} is not a run's record" in said
        assert (folder / "evaluation.json.damaged").read_text() == text
        same_numbers(records(copy)[name]["results"], before[name]["results"])
        assert len((folder / "attempts.log").read_text().splitlines()) == 2  # evaluated again
    (copy / "runs" / "DiffDrive-Random-v0_ppo_seed0" / "evaluation.json").write_text("")
    assert main([*flags[: flags.index("--output")], "--output", str(copy)]) == 0


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--eval-env-kwargs", '{"dt": -1}'], "--eval-env-kwargs for mobile_envs/DiffDrive"),
        (["--eval-env-kwargs", '{"bogus": 1}'], "'bogus'"),
        (["--eval-env-kwargs", "[1, 2]"], "--eval-env-kwargs"),
        (["--workers", "0"], "--workers"),
    ],
    ids=["dt", "unknown", "not-an-object", "workers"],
)
def test_bad_settings_are_refused_before_any_run_trains(tmp_path, extra, named, capsys):
    """Issue 30: a bad evaluation setting failed each run only after its whole training."""
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    try:
        status = main(grid_flags(tmp_path / "out", hyperparams, *extra))
    except SystemExit as exit:  # argparse's refusals
        status = exit.code
    assert status == 2
    assert named in capsys.readouterr().err
    assert not (tmp_path / "out" / "runs").exists()


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("default: [unclosed\n", "not valid YAML"),
        ("default:\n  n_steps: 0\n", "n_steps must be at least 1"),
        ("default:\n  env_kwargs: {dt: -1}\n", "env_kwargs for mobile_envs/DiffDrive-Random-v0"),
        ("default:\n  batch_size: 1\n  n_steps: 8\n", "PPO refuses these settings"),
    ],
    ids=["yaml", "n_steps", "env_kwargs", "sb3"],
)
def test_a_bad_hyperparameter_file_is_named_before_any_run_trains(tmp_path, text, named, capsys):
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(text)
    assert main(grid_flags(tmp_path / "out", hyperparams)) == 2
    error = capsys.readouterr().err
    assert str(hyperparams) in error and named in error
    assert not (tmp_path / "out" / "runs").exists()


def test_sigterm_stops_the_workers_waits_for_their_saves_and_says_how_to_finish(tmp_path):
    """Issue 30: SIGTERM ended the grid with 143 in silence, and its workers trained on,
    saved after their own SIGTERM and then hung until SIGKILL."""
    import os
    import signal
    import subprocess
    import sys
    import time

    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    output = tmp_path / "out"
    argv = [*grid_flags(output, hyperparams, "--workers", "2")]
    argv[argv.index("--timesteps") + 1] = "1000000"
    grid = subprocess.Popen(
        [sys.executable, "train.py", "grid", *argv],
        cwd=pathlib.Path(__file__).resolve().parents[1],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    runs = [output / "runs" / f"DiffDrive-Random-v0_ppo_seed{seed}" for seed in (0, 1)]
    deadline = time.monotonic() + 240
    while not all((run / "machine.yml").is_file() for run in runs):  # both are training
        assert grid.poll() is None, grid.communicate()
        assert time.monotonic() < deadline, "the runs never started"
        time.sleep(0.1)
    time.sleep(1.0)
    grid.send_signal(signal.SIGTERM)
    out, err = grid.communicate(timeout=240)
    assert grid.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert "interrupted by SIGTERM" in last and "finish the grid" in last
    assert last.endswith(shlex.join(["train.py", "grid", *argv])), last
    for run in runs:
        assert f"stopped: {run.name}" in out
        steps = load_policy(run / "checkpoints" / "latest.zip").num_timesteps
        assert 0 < steps < 1_000_000  # saved where it stopped
        (worker,) = [
            int(line.split()[-1]) for line in (run / "attempts.log").read_text().splitlines()
        ]
        with pytest.raises(ProcessLookupError):  # no worker left behind
            os.kill(worker, 0)


@pytest.mark.parametrize(
    ("signals", "says"),
    [
        (1, "the running runs saved their checkpoints"),
        (2, "a second signal stopped the running runs at once, without saving"),
    ],
)
def test_the_stop_message_says_whether_the_running_runs_saved(
    tmp_path, monkeypatch, capsys, signals, says
):
    """A second signal kills the workers before they save: the grid must not say they did."""
    import signal

    import agents.grid.grid as grid

    def stopped_run_grid(args, requests):
        signal.raise_signal(signal.SIGTERM)  # recorded: the workers stop at a step and save
        if signals == 2:
            signal.raise_signal(signal.SIGTERM)  # raises at once: the workers are killed
        requests.raise_if_requested()
        raise AssertionError("no stop came")

    monkeypatch.setattr(grid, "run_grid", stopped_run_grid)
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    argv = grid_flags(tmp_path / "out", hyperparams)
    assert main(argv) == 128 + signal.SIGTERM
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"interrupted by SIGTERM: {says}" in last
    assert last.endswith(shlex.join(["train.py", "grid", *argv])), last
    assert ("saved their checkpoints" in last) == (signals == 1)


# ---------------------------------------------------------------- issue 28


def test_classical_baselines_are_rows_measured_on_the_same_episodes(local_grid, tmp_path):
    """Issue 28: MPPI (and any classical agent) among the grid's agents, one evaluation per
    robot on the trained policies' episodes, read back when the command runs again."""
    from agents.controllers.mppi import MPPI
    from agents.grid.baselines import baseline_specs
    from agents.grid.grid import parse_args

    output, flags = local_grid
    copy = tmp_path / "grid"
    shutil.copytree(output, copy)
    argv = [*flags[: flags.index("--output")], "--output", str(copy), "--baselines", "mppi"]
    assert main(argv) == 0
    record = records(copy)["DiffDrive_mppi"]
    for env_id in ("mobile_envs/DiffDrive-Random-v0", "mobile_envs/DiffDrive-Lines-v0"):
        same_numbers(record["results"][env_id], evaluate(MPPI, env_id, 2, seed=1_000_000).summary)
    rows = json.loads((copy / "grid.json").read_text())["rows"]
    (lines,) = [row for row in rows if row["agent"] == "mppi" and row["path set"] == "Lines"]
    assert lines["runs"] == 1 and math.isnan(lines["mean_abs_cte"]["ci95"])
    summary = record["results"]["mobile_envs/DiffDrive-Lines-v0"]
    score, done = summary["mean_abs_cte"], summary["completion_rate"]
    assert lines["mean_abs_cte"]["mean"] == score
    cells = f"| DiffDrive | Lines | mppi | 1 | {done:.2f} | {done:.2f} [{done:.2f}, {done:.2f}] | "
    assert f"{cells}{score:.4f} | " in (copy / "grid.md").read_text()
    before = (copy / "grid.json").read_text()
    assert main(argv) == 0  # read back, not evaluated again
    assert (copy / "grid.json").read_text() == before
    args = parse_args(
        ["--baselines", "tricycle_guidance", "--envs", "mobile_envs/Bicycle-Random-v0"]
    )
    with pytest.raises(ValueError, match="tricycle_guidance drives none of Bicycle"):
        baseline_specs(args.baselines, args.envs, ["Lines"], 1, 0, {})
    with pytest.raises(ValueError, match="--baselines: unknown agent 'moon'"):
        baseline_specs(["moon"], args.envs, ["Lines"], 1, 0, {})
