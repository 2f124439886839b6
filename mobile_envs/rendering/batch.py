"""One frame of a whole batch of robots, for the vector env's ``render_mode``.

The frame is a grid of tiles drawn with :mod:`mobile_envs.rendering.frame`'s :class:`Renderer` (its
view fitting, grid, walls, path and goal), each tile one track with every robot of the batch
that is on it:

- a path set of a few fixed tracks (the course sets, the maze) gets one tile per track, in
  the set's order, so the layout never changes and all N robots are on screen: the
  spread of 1024 robots along one path is what shows how a policy tracks it;
- a generated set (random paths, random mazes), where no two robots share a track, gets the
  first ``max_tiles`` robots' own tracks: drawing robot 0's path under all the others
  would put robots on paths they do not follow.

A robot on a track of neither kind (a path given at reset, ``options={"path": ...}``) gets
its track's tile after the set's, so every robot is drawn while there is room; past
``max_tiles`` tiles, the set's tracks without a robot give up theirs first.

Trails and preview points are left out: at N = 1024 they would hide the robots.
pygame is imported only when a :class:`VectorRenderer` is built or first draws; a copy or
an unpickled renderer (of an env that was copied) draws anew, as the single env's does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from mobile_envs.rendering.frame import (
    BACKGROUND,
    GROWTH_FRACTION,
    HEADING,
    RENDER_MODES,
    ROBOT,
    ROBOT_OUTLINE,
    Bounds,
    Renderer,
    Scene,
    bounding_box,
    union,
)
from mobile_envs.tracks.sets import Track

#: Most tiles in one frame (a 4 x 4 grid).
MAX_TILES = 16
#: Colour of the lines between tiles.
TILE_BORDER = (160, 160, 160)


def tile_grid(count: int) -> tuple[int, int]:
    """Rows and columns of the most nearly square grid that holds ``count`` tiles.

    :param count: number of tiles, at least 1.
    :return: ``(rows, columns)`` with ``columns >= rows``.
    """
    columns = math.ceil(math.sqrt(count))
    return math.ceil(count / columns), columns


class VectorRenderer:
    """Draws every robot of a batch into one RGB frame or one pygame window.

    :param render_mode: ``"rgb_array"`` to return frames, ``"human"`` to show a window.
    :param fps: frame rate the human window is held to.
    :param fixed_tracks: the path set's fixed tracks (empty for a generated set); when there
        are at most ``max_tiles`` of them, each gets its own tile.
    :param robot_radius: radius of each robot's footprint, metres.
    :param goal_radius: radius of the goal circle, metres.
    :param max_cross_track: the off-track distance that ends an episode, metres: each tile
        shows its path's corridor this wide, so live robots stay in view without refits.
    :param width: frame width, pixels.
    :param height: frame height, pixels.
    :param max_tiles: most tiles in a frame.
    :raises ValueError: on an unknown ``render_mode`` or a frame too small for its tiles.
    """

    def __init__(
        self,
        render_mode: str,
        fps: int,
        fixed_tracks: Sequence[Track],
        robot_radius: float,
        goal_radius: float,
        max_cross_track: float,
        width: int = 600,
        height: int = 600,
        max_tiles: int = MAX_TILES,
    ):
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        if max_tiles < 1:
            raise ValueError(f"max_tiles must be at least 1, got {max_tiles!r}")
        self.render_mode = render_mode
        self.fps = fps
        self.width = width
        self.height = height
        self.max_tiles = max_tiles
        self.robot_radius = robot_radius
        self.goal_radius = goal_radius
        self.max_cross_track = max_cross_track
        self.fixed_tracks = tuple(fixed_tracks) if len(fixed_tracks) <= max_tiles else ()
        # The tiles' renderers draw off screen; their surfaces are pasted into this frame.
        self._frame = Renderer(render_mode, fps, width, height)
        self._pygame = self._frame._pygame
        self._tiles: list[Renderer] = []
        self._tile_tracks: list[Track | None] = []
        self._rows = self._columns = 0

    def __getstate__(self) -> dict[str, object]:
        # pygame's module and surfaces neither pickle nor copy: a copy draws anew.
        state = self.__dict__.copy()
        for name in ("_frame", "_pygame", "_tiles", "_tile_tracks"):
            del state[name]
        state["_rows"] = state["_columns"] = 0
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._tiles, self._tile_tracks = [], []

    def _open_frame(self) -> None:
        """The frame's renderer, made again by a copy's first draw (a window, for "human")."""
        if "_frame" not in self.__dict__:
            self._frame = Renderer(self.render_mode, self.fps, self.width, self.height)
            self._pygame = self._frame._pygame

    def tiles_for(self, tracks: Sequence[Track | None]) -> list[Track]:
        """The tracks that get a tile, in order: the path set's fixed tracks (or, for a
        generated set, the first robots' own), then any other track a robot is on; at most
        ``max_tiles``, the fixed tracks no robot is on giving way first.

        :param tracks: each robot's current track
        """
        present = {id(track) for track in tracks if track is not None}
        shown = list(self.fixed_tracks) or [
            track for track in tracks[: self.max_tiles] if track is not None
        ]
        known = {id(track) for track in shown}
        for track in tracks:
            if track is not None and id(track) not in known:
                shown.append(track)
                known.add(id(track))
        while len(shown) > self.max_tiles:
            empty = [index for index, track in enumerate(shown) if id(track) not in present]
            if not empty:
                return shown[: self.max_tiles]
            del shown[empty[-1]]
        return shown

    def render(
        self, tracks: Sequence[Track | None], poses: NDArray[np.float64]
    ) -> NDArray[np.uint8] | None:
        """Draw one frame of the batch.

        :param tracks: each robot's current track.
        :param poses: ``(N, 3)`` poses ``(x, y, heading)``.
        :return: in ``"rgb_array"`` mode the frame, ``(height, width, 3)`` uint8; in
            ``"human"`` mode ``None`` (the frame goes to the window).
        """
        self._open_frame()
        shown = self.tiles_for(tracks)
        self._layout(len(shown))
        robots_on: dict[int, list[int]] = {id(track): [] for track in shown}
        for robot, track in enumerate(tracks):
            on_tile = robots_on.get(id(track))
            if on_tile is not None:
                on_tile.append(robot)
        screen = self._frame.screen
        screen.fill(TILE_BORDER)
        tile_width, tile_height = self.width // self._columns, self.height // self._rows
        # One pixel of border between tiles: each tile is pasted one pixel smaller.
        border = 1 if len(shown) > 1 else 0
        for index, (renderer, track) in enumerate(zip(self._tiles, shown, strict=True)):
            self._draw_tile(index, renderer, track, poses[robots_on[id(track)]])
            row, column = divmod(index, self._columns)
            screen.blit(
                renderer.screen,
                (column * tile_width, row * tile_height),
                (0, 0, tile_width - border, tile_height - border),
            )
        if self.render_mode == "human":
            self._pygame.event.pump()
            self._frame.clock.tick(self.fps)
            self._pygame.display.flip()
            return None
        return np.transpose(np.array(self._pygame.surfarray.pixels3d(screen)), (1, 0, 2))

    def close(self) -> None:
        """Close the window, if one is open. Safe to call more than once."""
        if "_frame" in self.__dict__:
            self._frame.close()

    def _layout(self, count: int) -> None:
        """One off-screen renderer per tile, rebuilt only when the number of tiles changes."""
        rows, columns = tile_grid(max(count, 1))
        if (rows, columns) == (self._rows, self._columns) and len(self._tiles) == count:
            return
        self._rows, self._columns = rows, columns
        tile_width, tile_height = self.width // columns, self.height // rows
        if min(tile_width, tile_height) < 8:
            raise ValueError(f"a {self.width}x{self.height} frame is too small for {count} tiles")
        self._tiles = [
            Renderer("rgb_array", self.fps, tile_width, tile_height) for _ in range(count)
        ]
        self._tile_tracks = [None] * count

    def _draw_tile(
        self, index: int, renderer: Renderer, track: Track, poses: NDArray[np.float64]
    ) -> None:
        """The track's walls, path and goal, and the robots on it, on the tile's surface."""
        path = track.path.points
        scene = Scene(
            path=path,
            walls=None if track.maze is None else track.maze.walls,
            pose=poses[0] if len(poses) else np.array([*path[0], 0.0]),
            robot_radius=self.robot_radius,
            trail=np.empty((0, 2)),
            preview=np.empty((0, 2)),
            goal_radius=self.goal_radius,
        )
        self._fit(index, renderer, track, scene, poses)
        renderer.screen.fill(BACKGROUND)
        renderer._draw_grid()
        renderer._draw_walls(scene)
        renderer._draw_path(scene)
        self._draw_robots(renderer, poses)

    def _fit(
        self,
        index: int,
        renderer: Renderer,
        track: Track,
        scene: Scene,
        poses: NDArray[np.float64],
    ) -> None:
        """Fit the tile to its track's corridor when the track changes; after that only grow
        the view, by a margin, when a robot leaves it (an ending step can take one past the
        corridor), so a video does not jitter."""
        robots = bounding_box(poses[:, :2], self.robot_radius) if len(poses) else None
        if self._tile_tracks[index] is not track:
            self._tile_tracks[index] = track
            boxes = [
                bounding_box(scene.path, self.max_cross_track + self.robot_radius),
                bounding_box(scene.path[-1], scene.goal_radius),
            ]
            if scene.walls is not None and len(scene.walls):
                boxes.append(bounding_box(scene.walls))
            if robots is not None:
                boxes.append(robots)
            renderer._set_bounds(union(*boxes))
            return
        bounds: Bounds = renderer._bounds
        if robots is None or (np.all(robots[0] >= bounds[0]) and np.all(robots[1] <= bounds[1])):
            return
        growth = GROWTH_FRACTION * np.max(bounds[1] - bounds[0])
        renderer._set_bounds(union(bounds, bounding_box(robots, growth)))

    def _draw_robots(self, renderer: Renderer, poses: NDArray[np.float64]) -> None:
        """Every robot as a filled circle with a heading line to its rim, placed in one
        vectorized transform (at N = 1024 a per-robot transform costs more than the drawing)."""
        if not len(poses):
            return
        heading = poses[:, 2]
        rims = poses[:, :2] + self.robot_radius * np.stack([np.cos(heading), np.sin(heading)], 1)
        centres = np.rint(renderer.world_to_screen(poses[:, :2])).astype(int).tolist()
        rim_pixels = np.rint(renderer.world_to_screen(rims)).astype(int).tolist()
        radius = renderer._length(self.robot_radius, minimum=2)
        line_width = 3 if radius >= 6 else 1
        gfxdraw, draw, screen = renderer._gfxdraw, self._pygame.draw, renderer.screen
        for (column, row), rim in zip(centres, rim_pixels, strict=True):
            gfxdraw.filled_circle(screen, column, row, radius, ROBOT)
            gfxdraw.aacircle(screen, column, row, radius, ROBOT_OUTLINE)
            draw.line(screen, HEADING, (column, row), rim, line_width)
