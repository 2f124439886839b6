"""Many mazes sensed in one call: their wall grids stacked into padded arrays.

Random mazes give every robot its own maze. :class:`MazePack` keeps the mazes robots drive
in, one *slot* each (reference counted, so robots sharing a maze share a slot and a slot is
reused once no robot drives in its maze), and senses every robot in its own maze with one
call into :func:`mobile_envs.world.maze.sense_packed` (or its parallel twin on more than one
thread): the kernel :meth:`Maze.sense` runs, so the results are the same bits.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mobile_envs._kernels.threads import on_threads, start_kernel_threads
from mobile_envs.world.maze import Maze, PackedWalls, sense_packed, sense_packed_parallel

Indices = NDArray[np.int64]


class MazePack:
    """The mazes of up to ``capacity`` slots, their grids padded to the largest maze's size.

    :param capacity: the most slots ever in use at once (one per robot is always enough).
    :param num_threads: the threads :meth:`sense` runs on (see :mod:`mobile_envs._kernels.threads`).
    """

    def __init__(self, capacity: int, num_threads: int = 1) -> None:
        self.capacity = capacity
        self.num_threads = num_threads
        if num_threads > 1:
            start_kernel_threads()
        #: The maze of each slot; None for a free slot.
        self.mazes: list[Maze | None] = []
        self._slot_of: dict[Maze, int] = {}
        self._users = np.zeros(0, dtype=np.int64)
        self._free: list[int] = []
        self.verticals = np.ones((0, 1, 2), dtype=bool)
        self.horizontals = np.ones((0, 2, 1), dtype=bool)
        #: (slots, 2) rows and cols of each slot's maze.
        self.sizes = np.zeros((0, 2), dtype=np.int64)
        #: (slots, 3) origin x, origin y and cell size of each slot's maze.
        self.frames = np.zeros((0, 3))

    def __len__(self) -> int:
        """Number of mazes in use."""
        return len(self._slot_of)

    def users(self, slot: int) -> int:
        """How many robots drive in the maze of ``slot``."""
        return int(self._users[slot])

    def acquire(self, maze: Maze) -> int:
        """The slot of ``maze``, for one more robot; the maze is packed on its first use."""
        slot = self._slot_of.get(maze)
        if slot is None:
            if not self._free:
                self._grow()
            slot = self._free.pop()
            self._pack(slot, maze)
        self._users[slot] += 1
        return slot

    def release(self, slot: int) -> None:
        """One robot leaves the maze of ``slot``; the slot is freed when no robot is left."""
        self._users[slot] -= 1
        if self._users[slot] == 0:
            maze = self.mazes[slot]
            assert maze is not None
            del self._slot_of[maze]
            self.mazes[slot] = None
            self._free.append(slot)

    def sense(
        self,
        poses: NDArray[np.float64],
        robots: Indices,
        robot_slots: Indices,
        radius: float,
        angles: NDArray[np.float64],
        max_range: float,
        collision_out: NDArray[np.bool_],
        ranges_out: NDArray[np.float64],
    ) -> None:
        """:meth:`Maze.sense` of robots ``robots``, each in the maze of its slot
        ``robot_slots[robot]`` (none: -1, then skipped), written into their rows of the
        outputs (N rows, as ``poses``). No validation, no allocation."""
        arguments = (
            poses, robots, robot_slots, float(radius), angles, float(max_range), self.walls,
            collision_out, ranges_out,
        )  # fmt: skip
        if self.num_threads > 1 and len(robots) > 1:
            on_threads(sense_packed_parallel, self.num_threads, *arguments)
        else:
            sense_packed(*arguments)

    @property
    def walls(self) -> PackedWalls:
        """Every slot's walls as :func:`~mobile_envs.world.maze.sense_packed` reads them
        (new arrays after a slot is added, so read it again after :meth:`acquire`)."""
        return (self.verticals, self.horizontals, self.sizes, self.frames)

    def _pack(self, slot: int, maze: Maze) -> None:
        rows, cols = maze.rows, maze.cols
        if rows > self.verticals.shape[1] or cols + 1 > self.verticals.shape[2]:
            self._resize(
                len(self.mazes),
                max(rows, self.verticals.shape[1]),
                max(cols, self.horizontals.shape[2]),
            )
        self.verticals[slot, :rows, : cols + 1] = maze.vertical_walls
        self.horizontals[slot, : rows + 1, :cols] = maze.horizontal_walls
        self.sizes[slot] = rows, cols
        self.frames[slot] = maze.origin[0], maze.origin[1], maze.cell_size
        self.mazes[slot] = maze
        self._slot_of[maze] = slot

    def _grow(self) -> None:
        """Double the slots (at most ``capacity``); the new ones start free."""
        old = len(self.mazes)
        new = min(max(2 * old, 1), self.capacity)
        self._resize(new, self.verticals.shape[1], self.horizontals.shape[2])
        self.mazes.extend([None] * (new - old))
        self._users = np.concatenate((self._users, np.zeros(new - old, dtype=np.int64)))
        self._free.extend(range(new - 1, old - 1, -1))

    def _resize(self, slots: int, rows: int, cols: int) -> None:
        """Reallocate the arrays for ``slots`` slots of up to ``rows`` x ``cols`` cells,
        keeping what they hold."""
        old_slots, old_rows, old_cols = (
            len(self.sizes),
            self.verticals.shape[1],
            self.horizontals.shape[2],
        )
        verticals = np.ones((slots, rows, cols + 1), dtype=bool)
        horizontals = np.ones((slots, rows + 1, cols), dtype=bool)
        verticals[:old_slots, :old_rows, : old_cols + 1] = self.verticals
        horizontals[:old_slots, : old_rows + 1, :old_cols] = self.horizontals
        sizes = np.zeros((slots, 2), dtype=np.int64)
        frames = np.zeros((slots, 3))
        sizes[:old_slots], frames[:old_slots] = self.sizes, self.frames
        self.verticals, self.horizontals, self.sizes, self.frames = (
            verticals,
            horizontals,
            sizes,
            frames,
        )
