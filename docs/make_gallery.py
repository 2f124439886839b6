"""Make the env gallery: one animated GIF per kinematic model x path set x agent, and its page.

Each GIF is one episode of the real env (``gym.make(id, render_mode="rgb_array")``) driven
by an agent as ``train.py compare`` makes it: the shipped PPO policy of the model
(``models/*.zip``), pure pursuit, regulated pure pursuit, and for the tricycle its guidance
law. Frames are every ``STEP_STRIDE``-th step, shrunk from the env's 600 x 600 to
``FRAME_SIZE`` pixels and mapped onto :func:`palette`: the renderer's own colours and their
blends with the background, so the trail stays orange, the preview points magenta and the
goal green, as in the env's frame::

    python docs/make_gallery.py          # writes docs/gallery/*.gif and docs/gallery.md

It takes a few minutes on one core (``--check`` prints the time and total size).
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
from agents.harness.policies import recorded_observation_settings
from mobile_envs.rendering import frame as colours

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
GALLERY = DOCS / "gallery"
MODELS = ("ConstantVelocity", "DiffDrive", "Bicycle", "Tricycle")
PATH_SETS = ("Lines", "Segments", "SharpSegments", "Maze", "Random")
#: Seed 003's run, a path set of the tricycle's own.
ARC_ID = "mobile_envs/Tricycle-ArcStraight-v0"
#: The shipped policies, by the model they drive.
POLICIES = {
    "ConstantVelocity": "models/constant_velocity_ppo.zip",
    "DiffDrive": "models/diffdrive_ppo.zip",
    "Bicycle": "models/bicycle_ppo.zip",
    "Tricycle": "models/tricycle_ppo.zip",
}
#: The classical agents (labels and compare's names); the guidance law drives the tricycle only.
CLASSICAL = (
    ("pure pursuit", "pure_pursuit"),
    ("regulated pure pursuit", "regulated_pure_pursuit"),
    ("tricycle guidance", "tricycle_guidance"),
)
#: One frame every this many steps (dt = 0.1 s: the GIF runs at 2.5x real time).
STEP_STRIDE = 4
#: Frame duration, milliseconds.
FRAME_MS = 160
#: Side of a GIF frame, pixels.
FRAME_SIZE = 320
#: Longest episode shown, steps.
STEP_LIMIT = 240
#: The seed of every episode, so the gallery is the same on every run.
SEED = 0
#: The renderer's colours (mobile_envs.rendering.frame), the goal's translucent fill as it
#: shows over the background.
RENDER_COLOURS = (
    colours.BACKGROUND,
    colours.GRID,
    colours.PATH,
    colours.GOAL,
    colours.WALL,
    colours.TRAIL,
    colours.PREVIEW,
    colours.ROBOT,
    colours.ROBOT_OUTLINE,
    colours.HEADING,
    colours.ESTIMATE,
    colours.REFLECTOR,
    colours.LASER,
    tuple(
        round(background + (fill - background) * colours.GOAL_FILL[3] / 255)
        for background, fill in zip(colours.BACKGROUND, colours.GOAL_FILL[:3], strict=True)
    ),
)
#: How much of a colour the blends with the background keep: shrinking a 2-pixel line to
#: about one pixel mixes it with what is beside it.
BLENDS = (0.25, 0.5, 0.75)


def palette() -> list[tuple[int, int, int]]:
    """The GIFs' colours: each of :data:`RENDER_COLOURS`, then its :data:`BLENDS` with the
    background (fewer than 64 colours in all)."""
    background = np.array(colours.BACKGROUND, dtype=float)
    entries = [tuple(colour) for colour in RENDER_COLOURS]
    for colour in RENDER_COLOURS[1:]:
        for keep in BLENDS:
            mixed = background + keep * (np.array(colour, dtype=float) - background)
            entries.append(tuple(int(value) for value in np.round(mixed)))
    return list(dict.fromkeys(entries))


def _palette_image() -> Image.Image:
    image = Image.new("P", (1, 1))
    flat = [value for colour in palette() for value in colour]
    image.putpalette(flat + flat[:3] * (256 - len(flat) // 3))
    return image


PALETTE_IMAGE = _palette_image()


def gif_frame(frame: NDArray[np.uint8]) -> Image.Image:
    """An env frame as a GIF frame: ``FRAME_SIZE`` pixels a side, each pixel the nearest
    colour of :func:`palette` (no dithering, which would speckle the white background)."""
    shrunk = Image.fromarray(frame).resize((FRAME_SIZE, FRAME_SIZE), Image.Resampling.LANCZOS)
    return shrunk.quantize(palette=PALETTE_IMAGE, dither=Image.Dither.NONE)


def agents_for(model: str) -> list[tuple[str, str]]:
    """(label, agent name for :func:`agents.harness.compare.make_agent`) for one model."""
    agents = [("PPO", "ppo:" + str(REPO / POLICIES[model]))]
    agents += [
        (label, name)
        for label, name in CLASSICAL
        if name != "tricycle_guidance" or model == "Tricycle"
    ]
    return agents


def record_episode(env_id: str, agent_name: str) -> list[Image.Image]:
    """One episode's frames, every ``STEP_STRIDE``-th step and the last, as GIF frames."""
    env = gym.make(env_id, render_mode="rgb_array", step_limit=STEP_LIMIT)
    agent = make_agent(agent_name, env)
    if agent is None:
        raise ValueError(f"{agent_name} cannot drive {env_id}")
    # A policy observes through the sensors it was trained with (a rendering env cannot be
    # batched, so the harness cannot remake it: this does).
    own_settings = recorded_observation_settings(agent)
    if own_settings:
        env.close()
        env = gym.make(env_id, render_mode="rgb_array", step_limit=STEP_LIMIT, **own_settings)
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
    return [gif_frame(frame) for frame in frames]


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
    """The gallery's Markdown: per model, a table of GIFs, a row per path set and a column per
    agent; the page hides the site's side bars, so three GIFs a row show near full size."""
    lines = [
        "---",
        "hide:",
        "  - navigation",
        "  - toc",
        "---",
        "",
        "# Env gallery",
        "",
        "One episode of each `mobile_envs/<Model>-<PathSet>-v0` env, seed 0, driven by each",
        "agent of the harness: the model's shipped PPO policy (`models/*.zip`), pure pursuit,",
        "regulated pure pursuit and, for the tricycle, its guidance law. A frame every",
        f"{STEP_STRIDE} steps (2.5x real time), at most {STEP_LIMIT} steps, {FRAME_SIZE} x "
        f"{FRAME_SIZE} pixels in the",
        "renderer's own colours: the path blue, the robot grey with a red heading line, its",
        "trail orange, its preview points magenta, the goal circle green, maze walls black.",
        "`Random` draws a new path or maze at every reset. An agent stops where its episode",
        "ends: at the goal, off the track, on a wall, or after the steps shown.",
        "",
        "Made by `python docs/make_gallery.py` (a few minutes): rerun it after a change to",
        "the envs, the renderer, the agents or the policies.",
    ]
    for model in MODELS:
        agents = [(label, gifs) for row_model, label, gifs in rows if row_model == model]
        lines += [
            "",
            f"## {model}",
            "",
            "| path set | " + " | ".join(label for label, _ in agents) + " |",
            "|---|" + "---|" * len(agents),
        ]
        for path_set in PATH_SETS:
            cells = [
                f"![{model} {path_set}, {label}](gallery/{gifs[path_set]})"
                for label, gifs in agents
            ]
            lines.append(f"| {path_set} | " + " | ".join(cells) + " |")
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
                print(f"{len(written)}: {gifs[path_set]}", flush=True)
            rows.append((model, label, gifs))
    arc_gif = GALLERY / gif_name(ARC_ID, "pure pursuit")
    write_gif(arc_gif, record_episode(ARC_ID, "pure_pursuit"))
    written.append(arc_gif)
    for stale in set(GALLERY.glob("*.gif")) - set(written):
        stale.unlink()  # a GIF of an agent or env the gallery no longer shows
        print(f"removed {stale.name}, which the gallery no longer shows")
    (DOCS / "gallery.md").write_text(gallery_page(rows))
    if args.check:
        size = sum(path.stat().st_size for path in written)
        seconds = time.perf_counter() - start
        print(f"{len(written)} GIFs, {size / 1e6:.2f} MB, {seconds:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
