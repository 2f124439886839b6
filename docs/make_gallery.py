"""Make the env gallery: one animated GIF per kinematic model x path set, and its page.

Each GIF is one episode of the real env (``gym.make(id, render_mode="rgb_array")``) driven
by pure pursuit and, for the models with a shipped policy (``models/*.zip``), by that PPO
policy too, built as ``train.py compare`` builds them. Frames are every
``STEP_STRIDE``-th step, shrunk to ``FRAME_SIZE`` pixels, so the gallery stays small::

    python docs/make_gallery.py          # writes docs/gallery/*.gif and docs/gallery.md

It takes well under a minute on one core (``--check`` prints the time and total size).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray
from PIL import Image

import mobile_envs  # noqa: F401  (registers the ids)
from agents.harness.compare import make_agent
from agents.harness.evaluate import bind_agent

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
GALLERY = DOCS / "gallery"
MODELS = ("ConstantVelocity", "DiffDrive", "Bicycle", "Tricycle")
PATH_SETS = ("Lines", "Segments", "SharpSegments", "Maze", "Random")
#: Seed 003's run, a path set of the tricycle's own.
ARC_ID = "mobile_envs/Tricycle-ArcStraight-v0"
#: The shipped policies, by the model they drive.
POLICIES = {"DiffDrive": "models/diffdrive_ppo.zip", "Bicycle": "models/bicycle_ppo.zip"}
#: One frame every this many steps (dt = 0.1 s: the GIF runs at 2.5x real time).
STEP_STRIDE = 4
#: Frame duration, milliseconds.
FRAME_MS = 160
#: Side of a GIF frame, pixels.
FRAME_SIZE = 160
#: Longest episode shown, steps.
STEP_LIMIT = 240
#: The seed of every episode, so the gallery is the same on every run.
SEED = 0


def agents_for(model: str) -> list[tuple[str, str]]:
    """(label, agent name for :func:`agents.harness.compare.make_agent`) for one model."""
    agents = [("pure pursuit", "pure_pursuit")]
    if model in POLICIES:
        agents.insert(0, ("PPO", "ppo:" + str(REPO / POLICIES[model])))
    return agents


def record_episode(env_id: str, agent_name: str) -> list[Image.Image]:
    """One episode's frames, every ``STEP_STRIDE``-th step and the last, as palette images."""
    env = gym.make(env_id, render_mode="rgb_array", step_limit=STEP_LIMIT)
    agent = make_agent(agent_name, env)
    if agent is None:
        raise ValueError(f"{agent_name} cannot drive {env_id}")
    agent = bind_agent(agent, env)
    observation, _ = env.reset(seed=SEED)
    frames = [_frame(env)]
    episode_start, step = True, 0
    while True:
        action, _ = agent.predict(
            observation, episode_start=np.array([episode_start]), deterministic=True
        )
        observation, _, terminated, truncated, _ = env.step(action)
        episode_start, step = False, step + 1
        if terminated or truncated or step % STEP_STRIDE == 0:
            frames.append(_frame(env))
        if terminated or truncated:
            break
    env.close()
    return [
        Image.fromarray(frame)
        .resize((FRAME_SIZE, FRAME_SIZE), Image.Resampling.LANCZOS)
        .quantize(colors=32)
        for frame in frames
    ]


def _frame(env: gym.Env) -> NDArray[np.uint8]:
    """The env's rgb_array frame."""
    frame = env.render()
    if not isinstance(frame, np.ndarray):
        raise TypeError(f"render() gave {type(frame).__name__}, not a frame")
    return frame


def gif_name(env_id: str, label: str) -> str:
    return f"{env_id.split('/')[1]}-{label.replace(' ', '-')}.gif".replace("-v0", "")


def write_gif(path: Path, frames: list[Image.Image]) -> None:
    # The last frame stays up longer, so the end of the episode can be seen.
    durations = [FRAME_MS] * (len(frames) - 1) + [1500]
    frames[0].save(
        path, save_all=True, append_images=frames[1:], duration=durations, loop=0, optimize=True
    )


def gallery_page(rows: list[tuple[str, str, dict[str, str]]]) -> str:
    """The gallery's Markdown: a table of GIFs, a row per model and agent."""
    lines = [
        "# Env gallery",
        "",
        "One episode of each `mobile_envs/<Model>-<PathSet>-v0` env, seed 0, driven by pure",
        "pursuit and, for the differential drive and the bicycle, by the shipped PPO policies",
        f"(`models/*.zip`). A frame every {STEP_STRIDE} steps, at most {STEP_LIMIT} steps;",
        "the robot is grey with a red heading line, its trail orange, its preview points",
        "magenta, the goal circle green. `Random` draws a new path or maze at every reset.",
        "",
        "Made by `python docs/make_gallery.py` (under a minute): rerun it after a change to",
        "the envs, the renderer or the policies.",
        "",
        "| model | agent | " + " | ".join(PATH_SETS) + " |",
        "|---|---|" + "---|" * len(PATH_SETS),
    ]
    for model, label, gifs in rows:
        cells = [f"![{model} {path_set}](gallery/{gifs[path_set]})" for path_set in PATH_SETS]
        lines.append(f"| {model} | {label} | " + " | ".join(cells) + " |")
    arc_gif = gif_name(ARC_ID, "pure pursuit")
    lines += [
        "",
        f"The tricycle on seed 003's arc-and-straight run (`{ARC_ID}`), with pure pursuit:",
        "",
        f"![Tricycle ArcStraight](gallery/{arc_gif})",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="print the time and total size")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    GALLERY.mkdir(exist_ok=True)
    rows = []
    written = []
    for model in MODELS:
        for label, agent_name in agents_for(model):
            gifs = {}
            for path_set in PATH_SETS:
                env_id = f"mobile_envs/{model}-{path_set}-v0"
                gifs[path_set] = gif_name(env_id, label)
                write_gif(GALLERY / gifs[path_set], record_episode(env_id, agent_name))
                written.append(GALLERY / gifs[path_set])
            rows.append((model, label, gifs))
    arc_gif = GALLERY / gif_name(ARC_ID, "pure pursuit")
    write_gif(arc_gif, record_episode(ARC_ID, "pure_pursuit"))
    written.append(arc_gif)
    (DOCS / "gallery.md").write_text(gallery_page(rows))
    if args.check:
        size = sum(path.stat().st_size for path in written)
        seconds = time.perf_counter() - start
        print(f"{len(written)} GIFs, {size / 1e6:.2f} MB, {seconds:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
