"""Control laws for many robots at once, and the interface the evaluation harness drives.

A :class:`BatchAgent` acts for the robots of one
:class:`~mobile_envs.envs.vector.PathFollowingVectorEnv`: it is told which robots start an
episode on which track (:meth:`~BatchAgent.reset`) and asked, each step, for the actions of
the robots still driving (:meth:`~BatchAgent.act`), all in one call. The harness
(:mod:`agents.harness.batch`) drives every agent through it:

- a classical agent (:class:`agents.controllers.base.ClassicalAgent`) through
  :class:`ClassicalBatchAgent`, over the agent's :class:`LawBatch`: the law's state for N
  robots in arrays, advanced for all of them by one compiled call. The single-robot agent is
  the batch of one, so each law is written once;
- a trained policy through its batched ``predict``
  (:class:`agents.harness.batch.PolicyBatchAgent`).

A new controller (the MPPI tracker of issue 28) plugs in either way: as a ``ClassicalAgent``
whose ``batch`` returns its ``LawBatch``, or as any object with ``reset`` and ``act``.
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mobile_envs.robots import KinematicModel
from mobile_envs.tracks.sets import Track
from mobile_envs.world.geometry import HEADING, LENGTH, START_X, START_Y
from mobile_envs.world.paths import Path, PathTable

Indices = NDArray[np.int64]

#: The robot index of a batch of one.
ONE_ROBOT = np.zeros(1, dtype=np.int64)


@runtime_checkable
class BatchAgent(Protocol):
    """What drives the robots of one vector env, all at once."""

    def reset(self, robots: Indices, tracks: Sequence[Track]) -> None:
        """Robots ``robots`` start new episodes, robot ``robots[j]`` on ``tracks[j]``.

        :param robots: robot indices of the vector env
        :param tracks: each one's track (its path and, in a maze, the maze)
        """

    def act(
        self,
        robots: Indices,
        observations: NDArray[np.float32],
        believed_states: NDArray[np.float64],
    ) -> NDArray[np.float32]:
        """The normalized actions of robots ``robots``, shape (len(robots), m).

        :param robots: the robots to act for (each reset since its episode began)
        :param observations: (N, D) every robot's observation
        :param believed_states: (N, k) every robot's believed state (the vector env's
            ``believed_states``: what its localization estimates, the truth when exact)
        """


def robot_indices(robots: ArrayLike) -> Indices:
    """``robots`` as the int64 array the compiled laws index with."""
    return np.ascontiguousarray(robots, dtype=np.int64).reshape(-1)


class PathArrays(NamedTuple):
    """The robots' paths as the compiled laws read them: views of a
    :class:`~mobile_envs.world.paths.PathTable`'s kernel arrays, robot r on row r. Waypoint j
    of robot r's path is ``(starts_x[c], starts_y[c])`` with ``c = spans[r, 0] + j`` for j up
    to its last segment ``spans[r, 1]``, then ``goals[r]``: the path's own points, bit for
    bit. The laws are compiled against these arrays, never against the table's layout, so
    their cached machine code depends on this package's sources alone.
    """

    #: (capacity,) x of each segment's start.
    starts_x: NDArray[np.float64]
    #: (capacity,) y of each segment's start.
    starts_y: NDArray[np.float64]
    #: (capacity,) each segment's length (m).
    segment_lengths: NDArray[np.float64]
    #: (capacity,) each segment's heading (rad).
    segment_headings: NDArray[np.float64]
    #: (N, 2) each robot's first column and last segment.
    spans: NDArray[np.int64]
    #: (N, 2) each robot's goal, its path's last point.
    goals: NDArray[np.float64]


class RobotPaths:
    """The path each of N robots follows, packed for the compiled laws: robot i's path is row
    i of a :class:`~mobile_envs.world.paths.PathTable`.

    :param num_robots: N
    """

    def __init__(self, num_robots: int):
        self.num_robots = num_robots
        self.table: PathTable | None = None
        #: (N,) whether each robot has been given a path.
        self.assigned = np.zeros(num_robots, dtype=bool)
        self._arrays: PathArrays | None = None  # the table's views, until it changes

    def assign(self, robots: Indices, paths: Sequence[Path]) -> None:
        """Robot ``robots[j]`` follows ``paths[j]`` from now on."""
        if len(robots) != len(paths):
            raise ValueError(f"got {len(robots)} robots and {len(paths)} paths")
        if not len(robots):
            return
        if self.table is None:
            # Every row needs a path: robots not given one yet hold the first until they are.
            rows = [paths[0]] * self.num_robots
            for robot, path in zip(robots.tolist(), paths, strict=True):
                rows[robot] = path
            self.table = PathTable(rows)
        else:
            self.table.set_paths(robots.tolist(), list(paths))
        self.assigned[robots] = True
        self._arrays = None

    def arrays(self, robots: Indices) -> PathArrays:
        """The paths' arrays (read them again after :meth:`assign`, which may move them),
        once every robot of ``robots`` has a path.

        :raises RuntimeError: naming the robots that have none
        """
        table = self.table
        if table is None or not self.assigned[robots].all():
            missing = robots[~self.assigned[robots]].tolist()
            raise RuntimeError(
                f"call reset(path) before asking for a command (robots without a path: {missing})"
            )
        if self._arrays is None:
            columns, spans, _, goals = table.kernel_arrays
            self._arrays = PathArrays(
                columns[START_X], columns[START_Y], columns[LENGTH], columns[HEADING], spans, goals
            )
        return self._arrays

    def project(
        self, robots: Indices, points: NDArray[np.float64], hints: NDArray[np.int64]
    ) -> NDArray[np.int64]:
        """The segment each robot's point projects onto
        (:meth:`~mobile_envs.world.paths.PathTable.project`): searching forward from its
        hint, or its whole path where the hint is -1.

        :param points: (len(robots), 2) one point per robot
        :param hints: (len(robots),) each robot's previous segment, -1 for none
        """
        assert self.table is not None
        segments = np.empty(len(robots), dtype=np.int64)
        for windowed in (False, True):
            chosen = (hints >= 0) if windowed else (hints < 0)
            if chosen.any():
                _, _, segments[chosen] = self.table.project(
                    robots[chosen], points[chosen], hints[chosen] if windowed else None
                )
        return segments


class LawBatch(ABC):
    """One control law's state for N robots, each on its own path.

    Subclasses hold the law's per-robot state in arrays and compute the commands of many
    robots in one compiled call; :class:`agents.controllers.base.ClassicalAgent` uses a batch
    of one for its single-robot methods.

    :param num_robots: N
    """

    def __init__(self, num_robots: int):
        self.num_robots = num_robots
        self.paths = RobotPaths(num_robots)

    def reset(self, robots: ArrayLike, paths: Sequence[Path]) -> None:
        """Robot ``robots[j]`` starts following ``paths[j]``: it forgets its previous path.

        :param robots: robot indices in [0, N)
        :param paths: each one's new path
        """
        indices = robot_indices(robots)
        self.paths.assign(indices, paths)
        self.restart(indices)

    @abstractmethod
    def restart(self, robots: Indices) -> None:
        """Forget the law's state of ``robots`` (their paths are already set)."""

    @abstractmethod
    def inputs(
        self, robots: Indices, states: NDArray[np.float64], model: KinematicModel, dt: float
    ) -> NDArray[np.float64]:
        """The native inputs of robots ``robots``, shape (len(robots), m).

        :param robots: the robots to command
        :param states: (N, k) every robot's (believed) state
        :param model: the robots' kinematic model
        :param dt: the control period (s)
        """


class TwistLawBatch(LawBatch):
    """A law that commands twists (v, omega), which every model follows through
    :meth:`~mobile_envs.robots.model.KinematicModel.inputs_for`."""

    @abstractmethod
    def twists(
        self,
        robots: Indices,
        states: NDArray[np.float64],
        dt: float = 0.1,
        turns_in_place: bool = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The commanded forward speeds v (m/s) and yaw rates omega (rad/s) of ``robots``.

        :param states: (N, k) every robot's (believed) state; (x, y, heading) come first
        :param dt: the control period (s), for laws that limit a rate of change
        :param turns_in_place: whether the robots can rotate on the spot
        """

    def turns_in_place(self, model: KinematicModel) -> bool:
        """Whether this law treats ``model`` as turning on the spot (laws that do not care
        say True)."""
        return True

    def inputs(
        self, robots: Indices, states: NDArray[np.float64], model: KinematicModel, dt: float
    ) -> NDArray[np.float64]:
        v, omega = self.twists(robots, states, dt, self.turns_in_place(model))
        return model.inputs_for(states[robots], v, omega, dt)


class PerRobotLaws(LawBatch):
    """A law written for one robot (an object with ``reset(path)`` and ``inputs(state,
    model, dt)``) run for N robots a robot at a time, each with its own copy of it: for laws
    without a compiled batch of their own.

    :param law: the law; it is copied, never modified
    :param num_robots: N
    """

    def __init__(self, law: Any, num_robots: int):
        super().__init__(num_robots)
        #: Each robot's own copy of the law.
        self.robots = [copy.deepcopy(law) for _ in range(num_robots)]
        self.started = np.zeros(num_robots, dtype=bool)

    def reset(self, robots: ArrayLike, paths: Sequence[Path]) -> None:
        indices = robot_indices(robots)
        if len(indices) != len(paths):
            raise ValueError(f"got {len(indices)} robots and {len(paths)} paths")
        for robot, path in zip(indices.tolist(), paths, strict=True):
            self.robots[robot].reset(path)
        self.started[indices] = True

    def restart(self, robots: Indices) -> None:
        """Nothing to forget here: :meth:`reset` restarts each robot's copy on its path."""

    def inputs(
        self, robots: Indices, states: NDArray[np.float64], model: KinematicModel, dt: float
    ) -> NDArray[np.float64]:
        if not self.started[robots].all():
            missing = robots[~self.started[robots]].tolist()
            raise RuntimeError(f"call reset(path) before asking for a command (robots {missing})")
        commands = [
            self.robots[robot].inputs(states[robot], model, dt) for robot in robots.tolist()
        ]
        return np.array(commands, dtype=np.float64).reshape(len(robots), model.input_dim)


class ClassicalBatchAgent:
    """A :class:`LawBatch` driving the robots of a vector env: a :class:`BatchAgent`.

    The law reads the robots' believed states, never the observations, as a controller on
    the robot reads its localization.

    :param laws: the law for the env's ``num_envs`` robots
    :param env: a :class:`~mobile_envs.envs.vector.PathFollowingVectorEnv`, possibly wrapped
    """

    def __init__(self, laws: LawBatch, env: Any):
        self.laws = laws
        self.env = env.unwrapped

    def reset(self, robots: Indices, tracks: Sequence[Track]) -> None:
        self.laws.reset(robots, [track.path for track in tracks])

    def act(
        self,
        robots: Indices,
        observations: NDArray[np.float32],
        believed_states: NDArray[np.float64],
    ) -> NDArray[np.float32]:
        env = self.env
        inputs = self.laws.inputs(robot_indices(robots), believed_states, env.model, env.dt)
        return env.action_from_inputs(inputs)
