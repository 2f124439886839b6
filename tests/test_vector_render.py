"""The vector env's frame of the whole batch: every robot drawn at its pose on its own track's
tile, stable layouts, videos recorded from the vector env and through SB3's VecVideoRecorder."""

import itertools
import os
import warnings

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pygame", reason="rendering needs the render extra")

from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.rendering.batch import VectorRenderer, tile_grid
from mobile_envs.rendering.frame import HEADING, ROBOT

# pygame is imported only when a renderer is built, so this still comes before it.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

FRAME = 600


def stepped(env_id: str, count: int, steps: int, seed: int = 0, **kwargs):
    """A vector env in rgb_array mode after ``steps`` slow random steps."""
    envs = gym.make_vec(env_id, num_envs=count, render_mode="rgb_array", **kwargs)
    assert isinstance(envs, PathFollowingVectorEnv)
    envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        envs.step(rng.uniform(0.0, 0.4, (count, 2)).astype(np.float32))
    return envs


def red_mask(frame: np.ndarray) -> np.ndarray:
    """Pixels of the heading lines' red (HEADING), the one colour only robots are drawn in."""
    return np.all(frame == np.array(HEADING, np.uint8), axis=-1)


def robot_centres(envs: PathFollowingVectorEnv, tile_of: dict[int, int]) -> np.ndarray:
    """Each listed robot's centre in frame pixels (column, row), from its tile's own view
    and the tile's place in the grid."""
    renderer = envs._renderer
    assert isinstance(renderer, VectorRenderer)
    rows, columns = tile_grid(len(renderer._tiles))
    tile_width, tile_height = FRAME // columns, FRAME // rows
    centres = []
    for robot, tile in tile_of.items():
        row, column = divmod(tile, columns)
        pixel = renderer._tiles[tile].world_to_screen(envs.poses[robot, :2])
        centre = np.rint(pixel).astype(int)
        # The tile's view holds each of its robots.
        assert 0 <= centre[0] < tile_width and 0 <= centre[1] < tile_height
        centres.append(centre + np.array([column * tile_width, row * tile_height]))
    return np.array(centres)


def assert_robots_drawn_at(
    frame: np.ndarray, centres: np.ndarray, last_on_tiles: list[int], radius: float
) -> None:
    """The pixels in the robots' own colours (footprint grey, heading red) are exactly the
    robots' footprints: each footprint holds some, none lie outside every footprint, and the
    last robot drawn on each tile (which nothing covers) shows its heading's red at its centre.
    """
    red = red_mask(frame)
    robot = red | np.all(frame == np.array(ROBOT, np.uint8), axis=-1)
    rows, columns = np.nonzero(robot)
    distance = np.hypot(columns[:, None] - centres[None, :, 0], rows[:, None] - centres[None, :, 1])
    assert distance.min(axis=1).max() <= radius + 1  # nothing drawn away from the robots
    assert np.all(distance.min(axis=0) <= 1.5)  # every robot drawn where it is (a pixel)
    for index in last_on_tiles:
        column, row = centres[index]
        assert red[row, column], (column, row)


def last_robot_on_each_tile(tile_of: dict[int, int]) -> list[int]:
    """The robots drawn last on their tile (robots are drawn in index order)."""
    return list({tile: robot for robot, tile in sorted(tile_of.items())}.values())


def test_tile_grid_is_the_most_nearly_square():
    assert [tile_grid(count) for count in (1, 2, 3, 4, 5, 9, 10, 16)] == [
        (1, 1),
        (1, 2),
        (2, 2),
        (2, 2),
        (2, 3),
        (3, 3),
        (3, 4),
        (4, 4),
    ]


def test_a_fixed_set_gets_a_tile_per_track_with_every_robot_on_its_own():
    envs = stepped("mobile_envs/DiffDrive-Lines-v0", count=12, steps=8, start_noise=0.3)
    frame = envs.render()
    assert frame.shape == (FRAME, FRAME, 3) and frame.dtype == np.uint8
    tracks = envs.config.path_set.tracks
    assert len(tracks) == 3 and len(envs._renderer._tiles) == 3  # a 2 x 2 grid, one empty
    tile_of = {robot: tracks.index(track) for robot, track in enumerate(envs.tracks)}
    assert len(set(tile_of.values())) > 1  # the robots are spread over several tiles
    radius = max(tile._length(envs.config.robot_radius) for tile in envs._renderer._tiles)
    centres = robot_centres(envs, tile_of)
    assert_robots_drawn_at(frame, centres, last_robot_on_each_tile(tile_of), radius)


def test_a_generated_set_tiles_the_first_robots_own_tracks():
    envs = stepped("mobile_envs/DiffDrive-Random-v0", count=20, steps=5)
    frame = envs.render()
    assert len(envs._renderer._tiles) == 16
    # Robots 16 to 19 are on tracks no tile shows: they are not drawn.
    tile_of = {robot: robot for robot in range(16)}
    radius = max(tile._length(envs.config.robot_radius) for tile in envs._renderer._tiles)
    centres = robot_centres(envs, tile_of)
    assert_robots_drawn_at(frame, centres, last_robot_on_each_tile(tile_of), radius)


def test_frames_follow_the_robots_and_repeat_with_the_seed():
    first = stepped("mobile_envs/Tricycle-Maze-v0", count=6, steps=4, seed=3)
    again = stepped("mobile_envs/Tricycle-Maze-v0", count=6, steps=4, seed=3)
    frame = first.render()
    np.testing.assert_array_equal(frame, again.render())
    first.step(np.full((6, 2), 0.5, np.float32))
    assert np.any(first.render() != frame)


def test_each_tile_shows_its_corridor_and_stays_put_while_no_episode_ends():
    envs = stepped("mobile_envs/DiffDrive-Lines-v0", count=9, steps=0, start_noise=0.3)
    envs.render()
    tiles = envs._renderer._tiles
    corridor = envs.config.max_cross_track + envs.config.robot_radius
    for tile, track in zip(tiles, envs.config.path_set.tracks, strict=True):
        points = track.path.points
        assert np.all(tile.bounds[0] <= points.min(axis=0) - corridor + 1e-9)
        assert np.all(tile.bounds[1] >= points.max(axis=0) + corridor - 1e-9)
    views = [tile.bounds.copy() for tile in tiles]
    rng = np.random.default_rng(5)
    for _ in range(12):
        _, _, terminated, truncated, _ = envs.step(
            rng.uniform(-0.5, 1.0, (9, 2)).astype(np.float32)
        )
        if np.any(terminated | truncated):
            break
        envs.render()
        for tile, view in zip(tiles, views, strict=True):
            np.testing.assert_array_equal(tile.bounds, view)


def read_video(path) -> np.ndarray:
    """The frames of a video file."""
    imageio = pytest.importorskip("imageio", reason="reading videos back needs imageio")
    # A comprehension, not list(): the reader's length is inf, which list() tries to allocate.
    return np.array([frame for frame in imageio.get_reader(str(path), "ffmpeg")])


def assert_frames_change(frames: np.ndarray, count: int) -> None:
    """At least ``count`` frames (an encoder may drop the last), most unlike the one before."""
    assert frames.shape[0] >= count and frames.shape[-1] == 3
    # Compression blurs a little: a change is a clear difference, not a few grey levels.
    changes = [
        np.abs(later.astype(int) - earlier.astype(int)).max()
        for earlier, later in itertools.pairwise(frames)
    ]
    assert sum(change > 64 for change in changes) >= count // 2


def test_a_video_of_the_vector_env(tmp_path):
    pytest.importorskip("moviepy", reason="writing videos needs moviepy")
    from gymnasium.utils.save_video import save_video

    envs = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=16, render_mode="rgb_array")
    envs.reset(seed=1)
    frames = [envs.render()]
    for _ in range(11):
        envs.step(np.full((16, 2), 0.8, np.float32))
        frames.append(envs.render())
    save_video(
        frames,
        str(tmp_path),
        episode_trigger=lambda episode: True,
        fps=envs.metadata["render_fps"],
    )
    envs.close()
    assert_frames_change(read_video(tmp_path / "rl-video-episode-0.mp4"), 12)


def test_sb3_vec_video_recorder_records_the_adapter(tmp_path):
    pytest.importorskip("stable_baselines3", reason="the adapter needs the train extra")
    pytest.importorskip("moviepy", reason="writing videos needs moviepy")
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv

    adapter = PathFollowingSB3VecEnv(
        "mobile_envs/DiffDrive-Segments-v0", 8, seed=0, render_mode="rgb_array"
    )
    assert adapter.render_mode == "rgb_array" and adapter.metadata["render_fps"] == 10
    recorder = VecVideoRecorder(
        adapter, str(tmp_path), record_video_trigger=lambda step: step == 0, video_length=10
    )
    recorder.reset()
    for _ in range(12):
        recorder.step(np.full((8, 2), 0.8, np.float32))
    recorder.close()
    (video,) = tmp_path.glob("*.mp4")
    assert_frames_change(read_video(video), 10)


def test_human_mode_draws_in_a_window():
    envs = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=4, render_mode="human")
    envs.reset(seed=0)
    assert envs.render() is None
    envs.close()
    envs.close()


def test_render_refuses_what_it_cannot_draw():
    with pytest.raises(ValueError, match="render_mode"):
        gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2, render_mode="ansi")
    envs = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2, render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="reset"):
        envs.render()
    plain = gym.make_vec("mobile_envs/DiffDrive-Lines-v0", num_envs=2)
    plain.reset(seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert plain.render() is None
    assert any("render_mode" in str(warning.message) for warning in caught)
    with pytest.raises(ValueError, match="max_tiles"):
        VectorRenderer("rgb_array", 10, (), 0.25, 0.1, 1.0, max_tiles=0)


def test_robots_on_a_path_given_at_reset_get_its_tile_beside_the_set_s():
    """Issue 30: robots reset onto a path of their own were on no tile and not drawn."""
    from mobile_envs.world.paths import Path

    envs = stepped("mobile_envs/DiffDrive-Segments-v0", count=6, steps=0)
    fixed = list(envs.config.path_set.tracks)
    mask = np.array([True, False, True, False, True, False])
    envs.reset(options={"path": Path([[0.0, 0.0], [30.0, 30.0]]), "reset_mask": mask})
    frame = envs.render()
    tracks = envs.tracks
    assert len(envs._renderer._tiles) == len(fixed) + 1
    tile_of = {
        robot: fixed.index(track) if track in fixed else len(fixed)
        for robot, track in enumerate(tracks)
    }
    assert {tile_of[robot] for robot in (0, 2, 4)} == {len(fixed)}
    radius = max(tile._length(envs.config.robot_radius) for tile in envs._renderer._tiles)
    centres = robot_centres(envs, tile_of)
    assert_robots_drawn_at(frame, centres, last_robot_on_each_tile(tile_of), radius)


def test_beyond_the_tiles_the_set_s_empty_tracks_give_way_first():
    from mobile_envs.world.paths import Path

    envs = stepped("mobile_envs/DiffDrive-Lines-v0", count=3, steps=0)
    fixed = list(envs.config.path_set.tracks)
    for robot in range(3):  # each robot on a path of its own
        mask = np.arange(3) == robot
        envs.reset(options={"path": Path([[0.0, 0.0], [5.0, robot + 1.0]]), "reset_mask": mask})
    renderer = VectorRenderer("rgb_array", 10, fixed, 0.25, 0.1, 1.0, max_tiles=3)
    assert [id(track) for track in renderer.tiles_for(envs.tracks)] == [
        id(track) for track in envs.tracks
    ]  # every robot is on a tile
    assert renderer.tiles_for([fixed[1], None, fixed[0]]) == fixed  # the set's own layout


@pytest.mark.parametrize("copy_with", ["deepcopy", "pickle"])
def test_a_vector_env_that_has_rendered_copies_and_its_copy_draws_the_same(copy_with):
    import copy
    import pickle

    envs = stepped("mobile_envs/DiffDrive-Lines-v0", count=4, steps=3)
    frame = envs.render()
    twin = copy.deepcopy(envs) if copy_with == "deepcopy" else pickle.loads(pickle.dumps(envs))
    np.testing.assert_array_equal(twin.render(), frame)
    actions = np.full((4, 2), 0.5, np.float32)
    envs.step(actions)
    twin.step(actions)
    np.testing.assert_array_equal(twin.render(), envs.render())
    twin.close()
    envs.close()
