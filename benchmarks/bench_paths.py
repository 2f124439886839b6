"""Speed of the batched path and maze queries.

Robots drive along the canonical maze route (0.06 m per step: 0.6 m/s at dt = 0.1 s) with some
lateral wander; every step projects all of them onto their paths with the previous step's
segment as hint, as the environments do. Reported: time per batched call and robot-queries
per second. For comparison: the global search (no hint), a table where every robot has its own
random path, the arc-length queries, and the maze's collision and range queries.

Run: ``python benchmarks/bench_paths.py`` (numpy runs these on one core).
"""

import time
from functools import partial

import numpy as np

from mobile_envs.tracks import the_maze
from mobile_envs.world.paths import PathTable, random_path

ROBOT_COUNTS = (1, 64, 1024, 4096, 8192)
STEPS = 40
STEP_LENGTH = 0.06
PREVIEW_OFFSETS = np.linspace(0.25, 2.5, 10)
RAY_ANGLES = np.linspace(-np.pi, np.pi, 16, endpoint=False)


def trajectories(table, rows, rng):
    """(STEPS, N, 2) positions of robots moving forward along their paths."""
    start = rng.uniform(0.0, 0.8, len(rows)) * table.lengths[rows]
    s = start + STEP_LENGTH * np.arange(STEPS)[:, None]
    wander = 0.1 * np.sin(s / 1.7 + rng.uniform(0, 2 * np.pi, len(rows)))
    heading = np.stack([table.heading_at(rows, step_s) for step_s in s])
    points = np.stack([table.point_at(rows, step_s) for step_s in s])
    normal = np.stack((-np.sin(heading), np.cos(heading)), axis=-1)
    return points + wander[..., None] * normal, s


def best_seconds(run, calls=1, repeats=5):
    """Seconds per call: the best of several timings of run(), which makes ``calls`` calls."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best / calls


def time_projection(table, rows, positions, hinted):
    first_hint = table.project(rows, positions[0])[2]

    def run():
        hint = first_hint
        for xy in positions:
            _, _, hint = table.project(rows, xy, hint if hinted else None)

    return best_seconds(run, calls=STEPS)


def report(label, robots, seconds):
    print(f"{label:<34} {robots:>6} {seconds * 1e6:>11.1f} {robots / seconds:>14,.0f}")


def main():
    rng = np.random.default_rng(0)
    route = the_maze().path
    print(f"maze route: {route.num_segments} segments, {route.length:.1f} m\n")
    print(f"{'query':<34} {'robots':>6} {'us / call':>11} {'queries / s':>14}")
    for robots in ROBOT_COUNTS:
        table = PathTable([route])
        rows = np.zeros(robots, dtype=np.intp)
        positions, _ = trajectories(table, rows, rng)
        report("project, hint, maze route", robots, time_projection(table, rows, positions, True))
    for robots in (1024, 4096):
        table = PathTable([route])
        rows = np.zeros(robots, dtype=np.intp)
        positions, _ = trajectories(table, rows, rng)
        seconds = time_projection(table, rows, positions, False)
        report("project, global, maze route", robots, seconds)

    for robots in (1024, 4096):
        table = PathTable([random_path(rng) for _ in range(robots)])
        rows = np.arange(robots)
        positions, s = trajectories(table, rows, rng)
        report("project, hint, random", robots, time_projection(table, rows, positions, True))
        pose = np.column_stack((positions[0], np.zeros(robots)))
        report("point_at, random", robots, best_seconds(partial(table.point_at, rows, s[0])))
        preview = partial(table.preview, rows, pose, s[0], PREVIEW_OFFSETS)
        report("preview 10 points, random", robots, best_seconds(preview))

    maze = the_maze().maze
    for robots in (1024, 4096):
        table = PathTable([route])
        positions, _ = trajectories(table, np.zeros(robots, dtype=np.intp), rng)
        poses = np.column_stack((positions[0], rng.uniform(-np.pi, np.pi, robots)))
        report("maze collides", robots, best_seconds(partial(maze.collides, poses, 0.3)))
        ranges = partial(maze.ranges, poses, RAY_ANGLES, 3.0)
        report("maze ranges, 16 rays, 3 m", robots, best_seconds(ranges))


if __name__ == "__main__":
    main()
