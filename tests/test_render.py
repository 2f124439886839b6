"""The renderer's frames: shape, content where the scene puts it, a stable view, human mode."""

import dataclasses
import importlib.util
import os
import sys

import numpy as np
import pytest
from gymnasium.error import DependencyNotInstalled

from mobile_envs.rendering.frame import Renderer, Scene

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("pygame") is None, reason="drawing needs pygame (the render extra)"
)

# pygame is imported only when a Renderer is built, so this still comes before it.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

SCENE = Scene(
    path=np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]),
    walls=None,
    pose=np.array([1.0, 1.5, 0.0]),
    robot_radius=0.25,
    trail=np.array([[0.0, 0.0]]),
    preview=np.array([[1.5, 0.0], [2.0, 0.0]]),
    goal_radius=0.2,
)


def scene_with(**changes) -> Scene:
    """The test scene with some fields replaced."""
    return dataclasses.replace(SCENE, **changes)


def robot_pixel_radius(renderer: Renderer, scene: Scene) -> float:
    """The robot's footprint radius on screen, pixels."""
    return scene.robot_radius * renderer.scale


def red_mask(frame: np.ndarray) -> np.ndarray:
    """Pixels of the heading line's red (not the orange trail, not the magenta preview)."""
    red, green, blue = (frame[..., channel].astype(int) for channel in range(3))
    return (red > 180) & (green < 60) & (blue < 60)


@pytest.mark.parametrize(("width", "height"), [(600, 600), (320, 200)])
def test_rgb_array_frame_has_the_requested_shape_and_content(width, height):
    renderer = Renderer("rgb_array", fps=10, width=width, height=height)
    frame = renderer.render(SCENE)
    assert frame.shape == (height, width, 3)
    assert frame.dtype == np.uint8
    assert (frame != 255).any(axis=-1).mean() > 0.01, "frame is (almost) blank"
    renderer.close()


def test_view_keeps_the_aspect_ratio_puts_y_up_and_shows_the_whole_scene():
    renderer = Renderer("rgb_array", fps=10, width=600, height=400)
    renderer.render(SCENE)
    origin, right, up = renderer.world_to_screen([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert right[0] - origin[0] == pytest.approx(origin[1] - up[1])
    assert right[0] - origin[0] > 0
    shown = np.concatenate([SCENE.path, SCENE.trail, SCENE.pose[None, :2]])
    pixels = renderer.world_to_screen(shown)
    assert (pixels >= 0).all()
    assert (pixels < [600, 400]).all()


def test_moving_the_robot_changes_pixels_only_near_its_old_and_new_positions():
    renderer = Renderer("rgb_array", fps=10)
    before_pose, after_pose = np.array([1.0, 1.5, 0.3]), np.array([3.0, 1.5, -0.3])
    before = renderer.render(scene_with(pose=before_pose))
    bounds = renderer.bounds.copy()
    after = renderer.render(scene_with(pose=after_pose))
    np.testing.assert_array_equal(renderer.bounds, bounds)

    rows, columns = np.nonzero((before != after).any(axis=-1))
    changed = np.stack([columns, rows], axis=-1)
    centres = renderer.world_to_screen([before_pose[:2], after_pose[:2]])
    distances = np.linalg.norm(changed[:, None, :] - centres[None, :, :], axis=-1)
    reach = robot_pixel_radius(renderer, SCENE) + 3
    assert (distances.min(axis=1) <= reach).all(), "a pixel far from the robot changed"
    assert (distances <= reach).any(axis=0).all(), "the old or the new footprint did not change"


@pytest.mark.parametrize("heading", [0.0, np.pi / 2, np.pi, -np.pi / 2, 0.7])
def test_heading_line_points_along_the_heading(heading):
    renderer = Renderer("rgb_array", fps=10)
    scene = scene_with(pose=np.array([1.0, 1.5, heading]))
    frame = renderer.render(scene)
    centre = renderer.world_to_screen(scene.pose[:2])
    radius = robot_pixel_radius(renderer, scene)
    rows, columns = np.nonzero(red_mask(frame))
    offsets = np.stack([columns, rows], axis=-1) - centre
    near = offsets[np.linalg.norm(offsets, axis=-1) <= radius + 3]
    assert len(near) > 0, "no heading line on the robot"
    # Screen rows grow downwards, so the world's +y is the screen's -row.
    along = near @ np.array([np.cos(heading), -np.sin(heading)])
    assert along.min() >= -2, "red pixels behind the robot's centre"
    assert along.max() >= 0.8 * radius, "heading line does not reach the rim"


def test_heading_zero_has_red_to_the_right_and_none_to_the_left():
    renderer = Renderer("rgb_array", fps=10)
    frame = renderer.render(SCENE)
    column, row = np.rint(renderer.world_to_screen(SCENE.pose[:2])).astype(int)
    radius = round(robot_pixel_radius(renderer, SCENE))
    band = red_mask(frame)[row - 3 : row + 4]
    assert band[:, column + 3 : column + radius + 1].any()
    assert not band[:, column - radius - 3 : column - 2].any()


def test_a_wall_across_the_view_draws_dark_pixels_along_it():
    wall_y = 2.5
    walls = np.array([[[-0.5, wall_y], [4.5, wall_y]]])
    along_wall = np.stack([np.linspace(0.0, 3.5, 15), np.full(15, wall_y)], axis=-1)

    def darkness_along_wall(scene: Scene) -> np.ndarray:
        renderer = Renderer("rgb_array", fps=10)
        frame = renderer.render(scene)
        columns, rows = np.rint(renderer.world_to_screen(along_wall)).astype(int).T
        return (frame[rows, columns] < 80).all(axis=-1)

    assert darkness_along_wall(scene_with(walls=walls)).all()
    assert not darkness_along_wall(scene_with(walls=walls[:0])).any()
    assert not darkness_along_wall(SCENE).any()


def test_view_is_stable_while_the_robot_stays_inside_it():
    renderer = Renderer("rgb_array", fps=10)
    renderer.render(SCENE)
    fitted = renderer.bounds.copy()
    inside = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.0]])
    renderer.render(scene_with(pose=np.array([2.0, 1.0, 0.0]), trail=inside))
    np.testing.assert_array_equal(renderer.bounds, fitted)


def test_view_grows_in_steps_when_the_robot_leaves_it_and_refits_on_a_new_episode():
    renderer = Renderer("rgb_array", fps=10)
    renderer.render(SCENE)
    fitted = renderer.bounds.copy()

    trail = SCENE.trail
    bounds_per_step = []
    for x in (5.0, 5.1, 5.2):  # right of the path, in small steps
        pose = np.array([x, 1.5, 0.0])
        trail = np.concatenate([trail, pose[None, :2]])
        renderer.render(scene_with(pose=pose, trail=trail))
        column, row = renderer.world_to_screen(pose[:2])
        assert 0 <= column < 600 and 0 <= row < 600
        bounds_per_step.append(renderer.bounds.copy())
    assert not np.array_equal(bounds_per_step[0], fitted)
    np.testing.assert_array_equal(
        bounds_per_step[0], bounds_per_step[-1], err_msg="view jitters step by step"
    )

    renderer.render(SCENE)
    np.testing.assert_array_equal(renderer.bounds, fitted)
    shifted = SCENE.path + np.array([10.0, 0.0])
    renderer.render(scene_with(path=shifted, pose=np.array([11.0, 1.5, 0.0]), trail=shifted[:1]))
    assert renderer.bounds[0, 0] > fitted[1, 0], "a new path did not refit the view"


def test_human_mode_draws_to_a_window_and_returns_none():
    renderer = Renderer("human", fps=1000)
    assert renderer.render(SCENE) is None
    assert renderer.render(scene_with(pose=np.array([2.0, 1.0, 1.0]))) is None
    renderer.close()
    renderer.close()


def test_unknown_render_mode_is_refused():
    with pytest.raises(ValueError, match="render_mode"):
        Renderer("ansi", fps=10)


def test_missing_pygame_asks_for_the_render_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)
    with pytest.raises(DependencyNotInstalled, match=r'pip install "mobile_envs\[render\]"'):
        Renderer("rgb_array", fps=10)


def colour_mask(frame: np.ndarray, colour: tuple[int, int, int], tolerance: int = 12) -> np.ndarray:
    """Pixels within ``tolerance`` of ``colour`` in every channel."""
    return (np.abs(frame.astype(int) - np.array(colour)) <= tolerance).all(axis=-1)


def test_landmarks_sightings_and_the_estimate_are_drawn_where_the_scene_puts_them():
    from mobile_envs.rendering.frame import ESTIMATE, LASER, REFLECTOR

    landmarks = np.array([[-1.0, -1.0], [5.0, -1.0], [5.0, 4.0]])
    estimate = np.array([2.5, 1.0, np.pi / 2])
    scene = scene_with(
        estimated_pose=estimate,
        landmarks=landmarks,
        sightings=np.stack([np.broadcast_to(estimate[:2], (3, 2)), landmarks], axis=1),
    )
    renderer = Renderer("rgb_array", fps=10)
    frame = renderer.render(scene)
    bare = Renderer("rgb_array", fps=10).render(scene_with())
    for colour in (REFLECTOR, LASER, ESTIMATE):
        assert not colour_mask(bare, colour).any()
    columns, rows = np.rint(renderer.world_to_screen(landmarks)).astype(int).T
    assert colour_mask(frame, REFLECTOR)[rows, columns].all()
    # The laser lines: LASER pixels halfway along each, away from the path and the robot.
    halfway = renderer.world_to_screen(0.5 * (estimate[:2] + landmarks))
    laser = colour_mask(frame, LASER)
    for column, row in np.rint(halfway).astype(int):
        assert laser[row - 1 : row + 2, column - 1 : column + 2].any()
    # The estimate's heading line points up from its centre, inside its outline.
    centre = renderer.world_to_screen(estimate[:2])
    rows, columns = np.nonzero(colour_mask(frame, ESTIMATE))
    offsets = np.stack([columns, rows], axis=-1) - centre
    assert np.linalg.norm(offsets, axis=-1).max() <= robot_pixel_radius(renderer, scene) + 2
    assert (-offsets[:, 1]).max() >= 0.8 * robot_pixel_radius(renderer, scene)


def test_an_env_that_localizes_draws_its_reflectors_and_the_estimate_beside_the_truth():
    from mobile_envs.envs.path_following import PathFollowingEnv
    from mobile_envs.rendering.frame import ESTIMATE, REFLECTOR

    frames = {}
    for localization in ("exact", "odometry+beacons"):
        env = PathFollowingEnv(
            "diff_drive", "segments", localization=localization, render_mode="rgb_array"
        )
        env.reset(seed=0)
        for _ in range(5):
            env.step(np.array([0.6, 0.5], np.float32))
        frames[localization] = env.render()
        if localization != "exact":
            reflectors = env.core.localization.landmarks
            pixels = env._renderer.world_to_screen(reflectors)
        env.close()
    assert (frames["exact"] != frames["odometry+beacons"]).any()
    assert not colour_mask(frames["exact"], REFLECTOR).any()
    columns, rows = np.rint(pixels).astype(int).T
    assert colour_mask(frames["odometry+beacons"], REFLECTOR)[rows, columns].all()
    assert colour_mask(frames["odometry+beacons"], ESTIMATE).any()
