"""The docs gallery (issue 31, item 9): its GIFs are readable (320 px, the renderer's own
colours, every model with every agent) and each shows the env's real frames."""

import importlib.util
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mobile_envs  # noqa: F401  (registers the ids)
from mobile_envs.rendering import frame as colours

pytest.importorskip("pygame", reason="the env's frames need pygame (the render extra)")
Image = pytest.importorskip("PIL.Image", reason="the GIFs are read with Pillow")

DOCS = Path(__file__).resolve().parents[1] / "docs"
_spec = importlib.util.spec_from_file_location("make_gallery", DOCS / "make_gallery.py")
gallery = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gallery)

#: What a reader must tell apart on a frame (the issue: they collapsed to one pale purple).
DISTINCT = {
    "path": colours.PATH,
    "trail": colours.TRAIL,
    "preview": colours.PREVIEW,
    "robot": colours.ROBOT,
    "goal": colours.GOAL,
}


def family(colour) -> set[tuple[int, int, int]]:
    """A render colour and its blends with the background, as the palette holds them."""
    background = np.array(colours.BACKGROUND, dtype=float)
    blends = {
        tuple(int(v) for v in np.round(background + keep * (np.array(colour) - background)))
        for keep in gallery.BLENDS
    }
    return {tuple(colour)} | blends


def pixel_counts(image: np.ndarray) -> dict[tuple[int, int, int], int]:
    values, counts = np.unique(image.reshape(-1, 3), axis=0, return_counts=True)
    return {
        tuple(int(v) for v in value): int(count)
        for value, count in zip(values, counts, strict=True)
    }


def env_frame_after(env_id: str, steps: int) -> np.ndarray:
    """The env's own 600 x 600 frame, pure pursuit having driven ``steps`` steps from seed 0."""
    env = gym.make(env_id, render_mode="rgb_array")
    agent = gallery.bind_agent(gallery.make_agent("pure_pursuit", env), env)
    observation, _ = env.reset(seed=gallery.SEED)
    for _ in range(steps):
        observation, *_ = env.step(agent.predict(observation, deterministic=True)[0])
    frame = env.render()
    env.close()
    return frame


def test_a_gif_frame_keeps_the_colours_of_the_env_frame():
    frame = env_frame_after("mobile_envs/DiffDrive-Segments-v0", 60)
    shown = np.array(gallery.gif_frame(frame).convert("RGB"))
    assert shown.shape == (gallery.FRAME_SIZE, gallery.FRAME_SIZE, 3)
    assert gallery.FRAME_SIZE >= 320
    original, reduced = pixel_counts(frame), pixel_counts(shown)
    assert set(reduced) <= set(gallery.palette())
    area = (gallery.FRAME_SIZE / frame.shape[0]) ** 2
    for name, colour in DISTINCT.items():
        assert original.get(colour, 0) > 0, f"the env frame shows the {name}"
        # Its pixels, in its own colour or blended with the background at its edges (the
        # goal's thin circle only so), cover about the area they had: no other colour took
        # them, and they took no other colour's.
        kept = sum(reduced.get(shade, 0) for shade in family(colour))
        assert kept > 0, f"the GIF frame shows the {name}"
        if original[colour] >= 50:  # the goal's circle is a few pixels of the env frame
            assert 0.3 < kept / (original[colour] * area) < 3.0, name
        if name != "goal":
            assert reduced.get(colour, 0) > 0, f"the GIF shows the {name} in its own colour"


GIFS = sorted((DOCS / "gallery").glob("*.gif"))


def expected_gifs() -> set[str]:
    names = {gallery.gif_name(gallery.ARC_ID, "pure pursuit")}
    for model in gallery.MODELS:
        for label, _ in gallery.agents_for(model):
            for path_set in gallery.PATH_SETS:
                names.add(gallery.gif_name(f"mobile_envs/{model}-{path_set}-v0", label))
    return names


def test_the_gallery_shows_every_model_with_every_agent_and_nothing_else():
    labels = {model: {label for label, _ in gallery.agents_for(model)} for model in gallery.MODELS}
    assert all(
        {"PPO", "pure pursuit", "regulated pure pursuit"} <= set(found) for found in labels.values()
    )
    assert "tricycle guidance" in labels["Tricycle"]
    assert {path.name for path in GIFS} == expected_gifs()
    page = (DOCS / "gallery.md").read_text()
    assert set(re.findall(r"\(gallery/([^)]+\.gif)\)", page)) == expected_gifs()
    assert sum(path.stat().st_size for path in GIFS) < 6_000_000  # a few MB


@pytest.mark.parametrize("path", GIFS, ids=[path.stem for path in GIFS])
def test_each_gif_is_320_px_in_the_palette_and_opens_on_the_envs_own_first_frame(path):
    with Image.open(path) as gif:
        assert gif.size == (gallery.FRAME_SIZE, gallery.FRAME_SIZE)
        assert gif.n_frames >= 2
        first = np.array(gif.convert("RGB"))
    assert set(pixel_counts(first)) <= set(gallery.palette())
    env_id = "mobile_envs/" + re.match(r"(\w+-\w+)-", path.name + "-")[1] + "-v0"
    expected = np.array(gallery.gif_frame(env_frame_after(env_id, 0)).convert("RGB"))
    np.testing.assert_array_equal(first, expected)
