"""compare's outputs (issue 31, item 6): it says where it writes, never mixes two comparisons
in one folder (a folder holding files is refused unless --overwrite, which removes the
previous comparison's table and plots), and its plots mark the start and the goal."""

import math

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="the compare command's plots need matplotlib")

from agents.harness import compare

LINES = "mobile_envs/DiffDrive-Lines-v0"
MAZE = "mobile_envs/DiffDrive-Maze-v0"


def run(output, envs, *extra):
    return compare.cli(
        ["--agents", "pure_pursuit", "--episodes", "1", "--envs", *envs, "--output", str(output),
         *extra]
    )  # fmt: skip


def test_a_second_comparison_into_the_same_folder_is_refused_and_changes_nothing(tmp_path, capsys):
    output = tmp_path / "comparison"
    assert run(output, [MAZE]) == 0
    printed = capsys.readouterr().out
    assert f"writing the comparison to {output}/" in printed
    assert f"wrote {output / 'comparison.md'} and 1 plot in {output}/" in printed
    before = {path.name: path.read_bytes() for path in output.iterdir()}
    assert run(output, [LINES]) == compare.EXIT_USAGE
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1
    assert f"--output: {output} already holds a comparison" in error and "--overwrite" in error
    assert {path.name: path.read_bytes() for path in output.iterdir()} == before


def test_overwrite_replaces_the_comparison_and_leaves_no_stale_plot(tmp_path):
    output = tmp_path / "comparison"
    assert run(output, [MAZE]) == 0
    notes = output / "notes.txt"
    notes.write_text("mine")
    assert run(output, [LINES], "--overwrite") == 0
    assert sorted(path.name for path in output.iterdir()) == [
        "DiffDrive-Lines-v0.png", "comparison.md", "notes.txt",
    ]  # fmt: skip
    assert "DiffDrive-Lines-v0" in (output / "comparison.md").read_text()
    assert "Maze" not in (output / "comparison.md").read_text()
    assert notes.read_text() == "mine"


def test_a_folder_of_other_files_is_refused_and_a_file_is_no_folder(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    assert run(tmp_path, [LINES]) == compare.EXIT_USAGE
    assert "already holds files" in capsys.readouterr().err
    assert run(tmp_path / "notes.txt", [LINES]) == compare.EXIT_USAGE
    assert "is a file, not a folder" in capsys.readouterr().err


def test_the_plot_marks_the_start_pose_and_the_goal(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from agents.controllers.pure_pursuit import PurePursuit
    from agents.harness.evaluate import evaluate

    figures = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *args, **kwargs: figures.append(self))
    result = evaluate(PurePursuit(), LINES, 1, seed=3, start_noise=[0.2, 0.3])
    compare.plot_first_episodes(LINES, {"pure_pursuit": result}, tmp_path / "x.png", 0.25)
    (axes,) = figures[0].axes
    lines = {line.get_label(): line for line in axes.get_lines()}
    assert {"path", "pure_pursuit (goal)", "start", "goal"} <= set(lines)
    episode = result.episodes[0]
    x, y, heading = episode.trajectory[0]
    np.testing.assert_array_equal(lines["start"].get_xydata(), [[x, y]])
    # The triangle points along the start heading (matplotlib's 3-gon points up at 0).
    assert lines["start"].get_marker() == (3, 0, pytest.approx(math.degrees(heading) - 90))
    np.testing.assert_array_equal(lines["goal"].get_xydata(), [episode.path.points[-1]])
    (circle,) = axes.patches
    assert circle.radius == 0.25 and tuple(circle.center) == tuple(episode.path.points[-1])
