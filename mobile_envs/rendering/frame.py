"""Frames for ``render_mode="rgb_array"`` and a window for ``"human"``, drawn with pygame.

Drawn the way Gymnasium's classic-control environments draw: on a ``pygame.Surface`` (the
display surface in human mode), read back with ``pygame.surfarray.pixels3d`` as an
``(height, width, 3)`` uint8 array. pygame is imported only when a :class:`Renderer` is built,
so ``import mobile_envs`` never needs it.

The world-to-screen transform keeps the aspect ratio, puts y up, and fits the path, the walls
and the goal circle at the start of an episode. Within an episode it only grows, when the robot
or its trail leaves the view, so a recorded video does not jitter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium.error import DependencyNotInstalled
from numpy.typing import ArrayLike, NDArray

RENDER_MODES = ("human", "rgb_array")

BACKGROUND = (255, 255, 255)
GRID = (235, 235, 235)
PATH = (20, 40, 160)
GOAL = (0, 160, 0)
GOAL_FILL = (0, 160, 0, 50)
WALL = (40, 40, 40)
TRAIL = (255, 140, 0)
PREVIEW = (220, 0, 220)
ROBOT = (150, 150, 150)
ROBOT_OUTLINE = (90, 90, 90)
HEADING = (220, 0, 0)
ESTIMATE = (0, 90, 230)
REFLECTOR = (0, 150, 150)
LASER = (120, 210, 210)

#: Empty border around the fitted bounds, as a fraction of the smaller screen side.
MARGIN_FRACTION = 0.05
#: When the robot leaves the view, the bounds grow by this fraction of their span beyond it,
#: so the view changes rarely rather than on every step.
GROWTH_FRACTION = 0.25
#: Drawn thickness of maze walls, metres (at least 3 pixels).
WALL_THICKNESS = 0.05
#: Smallest world span shown, metres, so a single-point scene still has a scale.
MIN_SPAN = 1.0
#: Drawn side of a reflector's square, metres (at least 3 pixels).
LANDMARK_SIZE = 0.15


@dataclass(frozen=True)
class Scene:
    """Everything one frame shows, in world coordinates (metres).

    :param path: ``(M, 2)`` path vertices.
    :param walls: ``(W, 2, 2)`` wall segments, or ``None`` when there are no walls.
    :param pose: ``(3,)`` robot pose ``(x, y, heading)``.
    :param robot_radius: radius of the robot's footprint circle.
    :param trail: ``(T, 2)`` positions visited so far this episode.
    :param preview: ``(K, 2)`` preview points the policy sees, in the world frame.
    :param goal_radius: radius of the goal circle around the last path vertex.
    :param estimated_pose: ``(3,)`` the pose the robot believes it has, drawn hollow beside
        the true one; ``None`` when the robot knows its pose.
    :param landmarks: ``(R, 2)`` reflectors (or other landmarks) the robot measures, drawn
        as small squares; ``None`` when there are none.
    :param sightings: ``(L, 2, 2)`` segments of the robot's last measurement (the laser
        lines of its last fix, from the head to each reflector it used).
    """

    path: np.ndarray
    walls: np.ndarray | None
    pose: np.ndarray
    robot_radius: float
    trail: np.ndarray
    preview: np.ndarray
    goal_radius: float
    estimated_pose: np.ndarray | None = None
    landmarks: np.ndarray | None = None
    sightings: np.ndarray | None = None


Bounds = NDArray[np.float64]
"""``(2, 2)`` array ``[[x_min, y_min], [x_max, y_max]]``."""


def bounding_box(points: ArrayLike, pad: float = 0.0) -> Bounds:
    """The axis-aligned box around ``points``, grown by ``pad`` on every side.

    :param points: any array whose last axis is ``(x, y)``.
    :param pad: distance added on every side.
    :return: ``[[x_min, y_min], [x_max, y_max]]``.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.array([points.min(axis=0) - pad, points.max(axis=0) + pad])


def union(*boxes: Bounds) -> Bounds:
    """The smallest box holding every one of ``boxes``."""
    return bounding_box(np.concatenate(boxes))


def robot_bounds(scene: Scene) -> Bounds:
    """The box around the robot's footprint and its trail."""
    footprint = bounding_box(scene.pose[:2], scene.robot_radius)
    if len(scene.trail) == 0:
        return footprint
    return union(footprint, bounding_box(scene.trail))


def episode_bounds(scene: Scene) -> Bounds:
    """The box fitted at the start of an episode: path, walls, goal circle, robot and
    landmarks."""
    boxes = [
        bounding_box(scene.path),
        bounding_box(scene.path[-1], scene.goal_radius),
        robot_bounds(scene),
    ]
    if scene.walls is not None and len(scene.walls):
        boxes.append(bounding_box(scene.walls))
    if scene.landmarks is not None and len(scene.landmarks):
        boxes.append(bounding_box(scene.landmarks, LANDMARK_SIZE))
    return union(*boxes)


class Renderer:
    """Draws :class:`Scene` objects into an RGB array or a pygame window.

    :param render_mode: ``"rgb_array"`` to return frames, ``"human"`` to show a window.
    :param fps: frame rate the human window is held to.
    :param width: frame width, pixels.
    :param height: frame height, pixels.
    :raises ValueError: on an unknown ``render_mode``.
    :raises DependencyNotInstalled: when pygame is missing.
    """

    def __init__(self, render_mode: str, fps: int, width: int = 600, height: int = 600):
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        try:
            import pygame
            from pygame import gfxdraw
        except ImportError as error:
            raise DependencyNotInstalled(
                'pygame is not installed, run `pip install "mobile_envs[render]"`'
            ) from error
        self._pygame = pygame
        self._gfxdraw = gfxdraw
        self.render_mode = render_mode
        self.fps = fps
        self.width = width
        self.height = height
        if render_mode == "human":
            pygame.display.init()
            pygame.display.set_caption("mobile_envs")
            self.screen = pygame.display.set_mode((width, height))
            self.clock = pygame.time.Clock()
        else:
            self.screen = pygame.Surface((width, height))
        self.bounds: Bounds | None = None
        self.scale = 1.0
        self._episode_path: NDArray[np.float64] | None = None
        self._trail_length = 0

    def render(self, scene: Scene) -> NDArray[np.uint8] | None:
        """Draw one frame.

        :param scene: what to draw.
        :return: in ``"rgb_array"`` mode the frame, ``(height, width, 3)`` uint8; in
            ``"human"`` mode ``None`` (the frame goes to the window).
        """
        self._fit(scene)
        self.screen.fill(BACKGROUND)
        self._draw_grid()
        self._draw_walls(scene)
        self._draw_sightings(scene)
        self._draw_landmarks(scene)
        self._draw_path(scene)
        self._draw_trail(scene)
        self._draw_preview(scene)
        self._draw_robot(scene)
        self._draw_estimate(scene)
        if self.render_mode == "human":
            self._pygame.event.pump()
            self.clock.tick(self.fps)
            self._pygame.display.flip()
            return None
        return np.transpose(np.array(self._pygame.surfarray.pixels3d(self.screen)), (1, 0, 2))

    def close(self) -> None:
        """Close the window, if one is open. Safe to call more than once."""
        if self.render_mode == "human" and self._pygame.display.get_init():
            self._pygame.display.quit()
            self._pygame.quit()

    def world_to_screen(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pixel coordinates ``(column, row)`` of world points, under the last frame's view.

        :param points: ``(..., 2)`` world points, metres.
        :return: ``(..., 2)`` pixel coordinates; row 0 is the top of the frame.
        :raises RuntimeError: before the first :meth:`render`.
        """
        if self.bounds is None:
            raise RuntimeError("call render() before world_to_screen()")
        points = np.asarray(points, dtype=np.float64)
        centre = self.bounds.mean(axis=0)
        column = self.width / 2 + (points[..., 0] - centre[0]) * self.scale
        row = self.height / 2 - (points[..., 1] - centre[1]) * self.scale
        return np.stack([column, row], axis=-1)

    def _fit(self, scene: Scene) -> None:
        """Refit the view to a new episode, or grow it to keep the robot and trail in sight.

        A new episode is a different path or a trail shorter than on the previous frame.
        """
        path = np.asarray(scene.path, dtype=np.float64)
        new_episode = (
            self._episode_path is None
            or not np.array_equal(path, self._episode_path)
            or len(scene.trail) < self._trail_length
        )
        self._trail_length = len(scene.trail)
        if new_episode:
            self._episode_path = path.copy()
            self._set_bounds(episode_bounds(scene))
            return
        robot, bounds = robot_bounds(scene), self._bounds
        if np.all(robot[0] >= bounds[0]) and np.all(robot[1] <= bounds[1]):
            return
        growth = GROWTH_FRACTION * np.max(bounds[1] - bounds[0])
        self._set_bounds(union(bounds, bounding_box(robot, growth)))

    @property
    def _bounds(self) -> Bounds:
        """The bounds in view, once the first frame has set them."""
        if self.bounds is None:
            raise RuntimeError("no frame has been drawn yet")
        return self.bounds

    def _set_bounds(self, bounds: Bounds) -> None:
        """Show ``bounds`` centred, as large as the margin allows, with equal x and y scales."""
        self.bounds = bounds
        span = np.maximum(bounds[1] - bounds[0], MIN_SPAN)
        margin = MARGIN_FRACTION * min(self.width, self.height)
        self.scale = min((self.width - 2 * margin) / span[0], (self.height - 2 * margin) / span[1])

    def _pixels(self, points: ArrayLike) -> list[tuple[int, int]]:
        """World points as integer pixel tuples, as pygame's drawing calls want them."""
        pixels = np.rint(self.world_to_screen(points)).astype(int).reshape(-1, 2)
        return [(int(column), int(row)) for column, row in pixels]

    def _length(self, metres: float, minimum: int = 1) -> int:
        """A world length in pixels, at least ``minimum``."""
        return max(minimum, round(metres * self.scale))

    def _draw_grid(self) -> None:
        """Light lines at a round spacing (a power of ten metres), about two to twenty a side."""
        low, high = self._bounds
        spacing = 10.0 ** np.floor(np.log10(max(np.max(high - low), MIN_SPAN) / 2))
        for x in np.arange(np.ceil(low[0] / spacing), np.floor(high[0] / spacing) + 1) * spacing:
            column = self._pixels([x, 0.0])[0][0]
            self._gfxdraw.vline(self.screen, column, 0, self.height - 1, GRID)
        for y in np.arange(np.ceil(low[1] / spacing), np.floor(high[1] / spacing) + 1) * spacing:
            row = self._pixels([0.0, y])[0][1]
            self._gfxdraw.hline(self.screen, 0, self.width - 1, row, GRID)

    def _draw_walls(self, scene: Scene) -> None:
        if scene.walls is None:
            return
        thickness = self._length(WALL_THICKNESS, minimum=3)
        for start, end in np.asarray(scene.walls).reshape(-1, 2, 2):
            start_pixel, end_pixel = self._pixels([start, end])
            self._pygame.draw.line(self.screen, WALL, start_pixel, end_pixel, thickness)

    def _draw_path(self, scene: Scene) -> None:
        """The path as a polyline with dotted vertices, and the goal circle at its end."""
        vertices = self._pixels(scene.path)
        if len(vertices) > 1:
            self._pygame.draw.lines(self.screen, PATH, False, vertices, 2)
        for column, row in vertices:
            self._gfxdraw.filled_circle(self.screen, column, row, 3, PATH)
        column, row = vertices[-1]
        radius = self._length(scene.goal_radius, minimum=2)
        self._gfxdraw.filled_circle(self.screen, column, row, radius, GOAL_FILL)
        self._gfxdraw.aacircle(self.screen, column, row, radius, GOAL)

    def _draw_trail(self, scene: Scene) -> None:
        trail = self._pixels(scene.trail)
        if len(trail) > 1:
            self._pygame.draw.lines(self.screen, TRAIL, False, trail, 2)

    def _draw_preview(self, scene: Scene) -> None:
        for column, row in self._pixels(scene.preview):
            self._gfxdraw.filled_circle(self.screen, column, row, 3, PREVIEW)

    def _draw_landmarks(self, scene: Scene) -> None:
        if scene.landmarks is None:
            return
        side = self._length(LANDMARK_SIZE, minimum=3)
        for column, row in self._pixels(scene.landmarks):
            square = (column - side // 2, row - side // 2, side, side)
            self._pygame.draw.rect(self.screen, REFLECTOR, square)

    def _draw_sightings(self, scene: Scene) -> None:
        if scene.sightings is None:
            return
        for start, end in np.asarray(scene.sightings).reshape(-1, 2, 2):
            start_pixel, end_pixel = self._pixels([start, end])
            self._pygame.draw.line(self.screen, LASER, start_pixel, end_pixel, 1)

    def _draw_estimate(self, scene: Scene) -> None:
        """The believed pose: the footprint's outline and a heading line, in blue."""
        if scene.estimated_pose is None:
            return
        x, y, heading = scene.estimated_pose[:3]
        rim = (x + scene.robot_radius * np.cos(heading), y + scene.robot_radius * np.sin(heading))
        (column, row), rim_pixel = self._pixels([(x, y), rim])
        radius = self._length(scene.robot_radius, minimum=3)
        self._gfxdraw.aacircle(self.screen, column, row, radius, ESTIMATE)
        self._gfxdraw.aacircle(self.screen, column, row, max(radius - 1, 1), ESTIMATE)
        self._pygame.draw.line(self.screen, ESTIMATE, (column, row), rim_pixel, 2)

    def _draw_robot(self, scene: Scene) -> None:
        """The footprint as a filled circle, with a heading line from its centre to its rim."""
        x, y, heading = scene.pose[:3]
        rim = (x + scene.robot_radius * np.cos(heading), y + scene.robot_radius * np.sin(heading))
        (column, row), rim_pixel = self._pixels([(x, y), rim])
        radius = self._length(scene.robot_radius, minimum=3)
        self._gfxdraw.filled_circle(self.screen, column, row, radius, ROBOT)
        self._gfxdraw.aacircle(self.screen, column, row, radius, ROBOT_OUTLINE)
        self._pygame.draw.line(self.screen, HEADING, (column, row), rim_pixel, 3)
