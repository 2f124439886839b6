"""Fuzzing what users hand the environments (constructor arguments, actions, reset options)
and MPPI (its parameters).

Whatever goes in, the only outcomes are a clean run (a few steps with finite observations in
[-1, 1], finite rewards within float32, finite infos) or a ValueError or TypeError whose
message names the argument: never a NaN, a hang or another exception type. Valid input must
run rather than be refused, and do what it says: an action acts as its float64 value (a
twin env stepped with that value gives the same bits), a reset option's path and start pose
are the ones the episode starts with.

Also the localization settings (every mode's, and the randomized localization's variants),
triangulation's input, and the sweep's and grid's command lines, whose settings must all be
checked (or refused, naming the flag) before anything trains.

Bounded for CI (a few hundred examples per test, tens for the command lines);
``python benchmarks/fuzz_long.py`` runs the same strategies and checks with many more
examples and prints how many gave each outcome (:data:`OUTCOMES`).
"""

from __future__ import annotations

import collections
import inspect
import json
import math
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("hypothesis", reason="the fuzz suite needs hypothesis (the dev extra)")

from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from tiny_runs import TINY_PPO

import mobile_envs  # noqa: F401  (registers the ids)
from agents.controllers.guidance import TricycleGuidance
from agents.controllers.mppi import MPPI
from agents.controllers.pure_pursuit import PurePursuit, RegulatedPurePursuit
from mobile_envs._kernels.angles import wrap_angle
from mobile_envs.envs.path_following import PathFollowingEnv
from mobile_envs.envs.vector import PathFollowingVectorEnv
from mobile_envs.robots import INTEGRATORS, MODELS, DifferentialDrive
from mobile_envs.sensing.beacons import FIX, HEADING_KEPT, NO_FIX, triangulate
from mobile_envs.sensing.localization import LOCALIZATIONS
from mobile_envs.sensing.sensors import RangeSensor
from mobile_envs.sim.config import REWARD_LIMIT, RewardWeights
from mobile_envs.tracks import Track, path_set
from mobile_envs.validation import REAL_TYPES
from mobile_envs.world.paths import Path

CI = settings(
    max_examples=250,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

#: How many examples gave each outcome, across the tests run in this process.
OUTCOMES: collections.Counter[str] = collections.Counter()


def record(outcome: str) -> None:
    OUTCOMES[outcome] += 1
    event(outcome)


# ---------------------------------------------------------------------------------------------
# Numbers as users pass them

SPECIAL_FLOATS = (
    0.0,
    -0.0,
    math.nan,
    math.inf,
    -math.inf,
    5e-324,
    1e-320,
    2.2250738585072014e-308,
    1.7976931348623157e308,
    1e-300,
    1e300,
    1e9,
    1e9 * (1 + 2**-52),
)
NUMPY_SCALAR_TYPES = (
    np.float16,
    np.float32,
    np.float64,
    np.longdouble,
    np.int8,
    np.int16,
    np.int32,
    np.int64,
    np.uint8,
    np.uint16,
    np.uint32,
    np.uint64,
)
NOT_NUMBERS = (
    True,
    False,
    np.True_,
    None,
    "0.1",
    "abc",
    b"1",
    1j,
    np.complex64(1),
    [0.1],
    (0.1, 0.2, 0.3),
    {"value": 0.1},
    object(),
    np.array([0.1, 0.2]),
    np.array(0.5),
)


@st.composite
def magnitudes(draw: Any) -> float:
    """mantissa x 10**k for k from -320 to 308, mostly positive (negatives fail at once)."""
    value = draw(st.floats(1.0, 9.999)) * 10.0 ** draw(st.integers(-320, 308))
    return -value if draw(st.integers(0, 4)) == 0 else value


python_reals = st.one_of(
    magnitudes(),
    st.sampled_from(SPECIAL_FLOATS),
    st.floats(0.01, 10.0),
    st.integers(-3, 100),
    st.sampled_from((10**25, 10**400, -(10**400))),
)


def as_numpy(value: float, numpy_type: type) -> Any:
    """``value`` as a numpy scalar of ``numpy_type``; ``value`` itself where numpy cannot
    hold it (an int type and NaN, say)."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        try:
            return numpy_type(value)
        except (OverflowError, ValueError):
            return value


numpy_reals = st.builds(as_numpy, python_reals, st.sampled_from(NUMPY_SCALAR_TYPES))
setting_values = st.one_of(python_reals, numpy_reals, st.sampled_from(NOT_NUMBERS))


# ---------------------------------------------------------------------------------------------
# Constructor arguments

ENV_SETTINGS = (
    "dt",
    "goal_radius",
    "max_cross_track",
    "step_limit",
    "start_noise",
    "robot_radius",
    "stall_time",
    "integrator",
)
#: Quick path sets (a random maze takes ~50 ms to carve) and wrong values.
PATHS = (
    "segments",
    "horizontal_line",
    "arc_straight",
    "random",
    "maze",
    "moon",
    "",
    7,
    None,
    [],
    [7],
    Path([[0, 0], [4, 3]]),
    [Path([[0, 0], [4, 3]]), Track(Path([[0, 0], [0, 5]]))],
    {Path([[0, 0], [4, 3]])},
)
MODEL_VALUES = (*MODELS, "hovercraft", None, 3, ["diff_drive"], DifferentialDrive())
SENSORS = (None, [], [RangeSensor()], (RangeSensor(rays=4, max_range=1.0),), 5, ["x"], "ab")
#: Small counts only: a valid huge one allocates that many robots (see the module's notes).
NUM_ENVS = (1, 3, np.int64(2), 0, -1, 2.5, math.inf, math.nan, True, "2", 10**25)
AUTORESET_MODES = ("NextStep", "SameStep", "Disabled", gym.vector.AutoresetMode.DISABLED, "x", 3)


@st.composite
def constructor_arguments(draw: Any) -> dict[str, Any]:
    """A single or vector env's arguments with one to three of them fuzzed; ``names``: the
    words an error about them may name."""
    kind = draw(st.sampled_from(("single", "single", "vector")))
    fuzzable = (*ENV_SETTINGS, "model", "paths", "model_params", "reward_weights", "sensors")
    if kind == "vector":
        fuzzable += ("num_envs", "max_episode_steps", "autoreset_mode")
    fuzzed = draw(st.sets(st.sampled_from(fuzzable), min_size=1, max_size=3))
    model = (
        draw(st.sampled_from(MODEL_VALUES))
        if "model" in fuzzed
        else draw(st.sampled_from(tuple(MODELS)))
    )
    arguments: dict[str, Any] = {
        "kind": kind,
        "model": model,
        "paths": draw(st.sampled_from(PATHS)) if "paths" in fuzzed else "segments",
        "settings": {},
        "weights": None,
        "names": set(),
    }
    names, settings_ = arguments["names"], arguments["settings"]
    for name in fuzzed & set(ENV_SETTINGS):
        if name == "integrator":
            value = draw(st.one_of(st.sampled_from(INTEGRATORS), setting_values, st.text()))
        elif name == "start_noise":
            value = draw(
                st.one_of(
                    setting_values,
                    st.tuples(setting_values, setting_values),
                    st.lists(python_reals, max_size=3),
                )
            )
        else:
            value = draw(setting_values)
        settings_[name] = value
        names.add(name)
    if "model_params" in fuzzed:
        known = MODELS[model].parameter_names if isinstance(model, str) and model in MODELS else ()
        keys = draw(st.sets(st.sampled_from((*known, "bogus")), min_size=1, max_size=3))
        params = {key: draw(setting_values) for key in keys}
        settings_["model_params"] = draw(st.sampled_from((params, params, [1], "wheel_radius")))
        names |= {"model_params", *keys}
    if "reward_weights" in fuzzed:
        fields = tuple(RewardWeights.__dataclass_fields__)
        keys = draw(st.sets(st.sampled_from(fields), min_size=1, max_size=3))
        arguments["weights"] = {key: draw(setting_values) for key in keys}
        names |= {"reward_weights", *keys}
    if "sensors" in fuzzed:
        settings_["sensors"] = draw(st.sampled_from(SENSORS))
        names.add("sensors")
    if kind == "vector":
        arguments["num_envs"] = draw(st.sampled_from(NUM_ENVS)) if "num_envs" in fuzzed else 2
        if "max_episode_steps" in fuzzed:
            settings_["max_episode_steps"] = draw(setting_values)
        if "autoreset_mode" in fuzzed:
            settings_["autoreset_mode"] = draw(st.sampled_from(AUTORESET_MODES))
        names |= fuzzed & {"num_envs", "max_episode_steps", "autoreset_mode"}
    names |= {"model"} & fuzzed
    if "paths" in fuzzed:
        names |= {"paths", "path set"}
    return arguments


def build(arguments: dict[str, Any]) -> Any:
    settings_ = dict(arguments["settings"])
    if arguments["weights"] is not None:
        settings_["reward_weights"] = RewardWeights(**arguments["weights"])
    if arguments["kind"] == "single":
        return PathFollowingEnv(arguments["model"], arguments["paths"], **settings_)
    return PathFollowingVectorEnv(
        arguments["num_envs"], arguments["model"], arguments["paths"], **settings_
    )


def assert_finite_step_info(info: dict[str, Any]) -> None:
    for key in ("cross_track_error", "heading_error", "progress", "pose"):
        assert np.isfinite(np.asarray(info[key], dtype=np.float64)).all(), key


def assert_clean_run(env: Any, steps: int = 4, seed: int = 0) -> None:
    """A few steps of random actions: finite observations in [-1, 1], finite rewards within
    float32 and finite infos, through episode ends."""
    vector = isinstance(env, PathFollowingVectorEnv)
    rng = np.random.default_rng(seed)
    observations, info = env.reset(seed=seed)
    for _ in range(steps):
        assert np.isfinite(observations).all() and np.abs(observations).max() <= 1.0
        assert_finite_step_info(info)
        actions = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        observations, rewards, terminated, truncated, info = env.step(actions)
        rewards = np.asarray(rewards, dtype=np.float64)
        assert np.isfinite(rewards).all() and np.abs(rewards).max() <= REWARD_LIMIT
        ended = np.asarray(terminated) | np.asarray(truncated)
        if not vector and ended:
            assert all(math.isfinite(value) for value in env.episode_metrics().values())
            observations, info = env.reset()
        elif vector and ended.any() and env.autoreset_mode == gym.vector.AutoresetMode.DISABLED:
            observations, _ = env.reset(options={"reset_mask": ended})
    assert np.isfinite(observations).all() and np.abs(observations).max() <= 1.0


def check_constructor(arguments: dict[str, Any]) -> None:
    """Build the env: a clean run, or an error naming one of the fuzzed arguments."""
    try:
        env = build(arguments)
    except (ValueError, TypeError) as error:
        named = sorted(name for name in arguments["names"] if name in str(error))
        assert named, f"{type(error).__name__}: {error} names none of {arguments['names']}"
        record(f"constructor refused ({type(error).__name__})")
        return
    assert_clean_run(env)
    record("constructor ran")


@CI
@given(constructor_arguments())
def test_constructor_arguments_run_cleanly_or_are_refused_by_name(arguments):
    check_constructor(arguments)


# ---------------------------------------------------------------------------------------------
# Actions

ACTION_DTYPES = (
    *(np.dtype(t) for t in NUMPY_SCALAR_TYPES),
    np.dtype(">f4"),
    np.dtype(">f8"),
    np.dtype("<f2"),
    np.dtype(bool),
    np.dtype(np.complex128),
    np.dtype(object),
    np.dtype("U8"),
    np.dtype("datetime64[s]"),
)
NOT_ARRAYS = (None, "abc", {"a": 1}, [[0.1, 0.2], [0.3]], object(), [None, 0.1], 0.5, 3)
action_values = st.one_of(
    st.floats(-2.0, 2.0),
    st.sampled_from((math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324, 70000.0)),
    st.integers(-(2**40), 2**40).map(float),
)


def cast(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """``values`` (float64) as ``dtype``, however numpy converts them."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        if dtype.kind == "M":
            return np.asarray(np.nan_to_num(values)).astype(np.int64).astype(dtype)
        return values.astype(dtype)


@st.composite
def actions_for(draw: Any, shape: tuple[int, ...]) -> Any:
    """An action as users pass one: mostly an array of ``shape`` of any dtype and memory
    layout, else another shape, a nested list, a scalar or something else entirely."""
    form = draw(st.sampled_from(("array",) * 6 + ("list", "other")))
    if form == "other":
        return draw(st.sampled_from(NOT_ARRAYS))
    wrong_shape = draw(st.integers(0, 4)) == 0
    array_shape = (
        draw(hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4))
        if wrong_shape
        else shape
    )
    values = draw(hnp.arrays(np.float64, array_shape, elements=action_values))
    dtype = draw(st.sampled_from(ACTION_DTYPES))
    array = cast(values, dtype)
    layout = draw(st.sampled_from(("c", "c", "fortran", "strided", "readonly")))
    if layout == "fortran":
        array = np.asfortranarray(array)
    elif layout == "strided" and array.ndim:
        array = np.repeat(array, 2, axis=-1)[..., ::2]
    elif layout == "readonly":
        array.flags.writeable = False
    return array.tolist() if form == "list" else array


def expected_float64(action: Any, shape: tuple[int, ...]) -> np.ndarray | None:
    """The float64 actions a valid ``action`` stands for, clipped to [-1, 1]; None when it
    must be refused (wrong shape, not real numbers, NaN or inf)."""
    try:
        array = np.asarray(action)
    except (TypeError, ValueError):
        return None
    if array.shape != shape or array.dtype.kind not in "fiu":
        return None
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        return None
    if array.dtype.kind == "f":
        return np.clip(array, -1, 1).astype(np.float64)
    return np.clip(array.astype(np.float64), -1.0, 1.0)


def assert_same(value: Any, reference: Any) -> None:
    """Equal bit for bit: arrays element for element, infos (dicts, or the SB3 adapter's list
    of them) key for key."""
    if isinstance(reference, dict):
        assert value.keys() == reference.keys()
        for key in reference:
            assert_same(value[key], reference[key])
    elif isinstance(reference, list):
        assert len(value) == len(reference)
        for item, expected in zip(value, reference, strict=True):
            assert_same(item, expected)
    else:
        np.testing.assert_array_equal(value, reference)


def check_action(env: Any, twin: Any, action: Any, shape: tuple[int, ...], seed: int) -> None:
    """Step ``env`` with ``action``: a ValueError naming the action, or exactly what the twin
    does under the float64 value the action holds."""
    for each in (env, twin):
        if hasattr(each, "step_async"):  # the SB3 adapter: seed() sets the next reset's seeds
            each.seed(seed)
            each.reset()
        else:
            each.reset(seed=seed)
    expected = expected_float64(action, shape)
    if expected is None:
        with pytest.raises(ValueError, match="action"):
            env.step(action)
        record("action refused (ValueError)")
        return
    got, want = env.step(action), twin.step(expected)
    for value, reference in zip(got[:4], want[:4], strict=True):
        assert_same(value, reference)
    assert np.isfinite(got[0]).all() and np.isfinite(np.asarray(got[1], dtype=np.float64)).all()
    record("action ran")


_SINGLE = (PathFollowingEnv("bicycle", "random"), PathFollowingEnv("bicycle", "random"))
_VECTOR = tuple(PathFollowingVectorEnv(3, "tricycle", "maze") for _ in range(2))


@CI
@given(actions_for((2,)), st.integers(0, 3))
def test_single_env_actions_of_any_dtype_and_shape(action, seed):
    check_action(*_SINGLE, action, (2,), seed)


@CI
@given(actions_for((3, 2)), st.integers(0, 3))
def test_vector_env_actions_of_any_dtype_and_shape(action, seed):
    check_action(*_VECTOR, action, (3, 2), seed)


@pytest.fixture(scope="module")
def adapters():
    sb3 = pytest.importorskip(
        "mobile_envs.envs.sb3", reason="the SB3 adapter needs the train extra"
    )
    return tuple(
        sb3.PathFollowingSB3VecEnv("mobile_envs/DiffDrive-Random-v0", 8, seed=1) for _ in range(2)
    )


def test_the_sb3_adapter_refuses_a_transposed_action_array(adapters):
    """(2, 8) for 8 robots of 2 actions used to be reshaped silently: robot 0 got [1, 1]."""
    adapter, _ = adapters
    adapter.reset()
    transposed = np.zeros((2, 8), np.float32)
    transposed[0] = 1.0
    with pytest.raises(ValueError, match=r"shape \(8, 2\)"):
        adapter.step(transposed)


def test_the_sb3_adapter_refuses_a_missing_action_by_name(adapters):
    adapter, _ = adapters
    adapter.reset()
    with pytest.raises(ValueError, match="action"):
        adapter.step(None)


@settings(CI, max_examples=120)
@given(actions=actions_for((8, 2)).filter(lambda actions: actions is not None))
@example(actions=np.ones((2, 8), np.float32))
@example(actions=np.ones(16, np.float32))
@example(actions=np.ones((8, 2), np.float16))
def test_sb3_adapter_actions_of_any_dtype_and_shape(adapters, actions):
    check_action(*adapters, actions, (8, 2), 0)


# ---------------------------------------------------------------------------------------------
# Reset options and seeds

ONE_PATH = Path([[0, 0], [3, 4]])
PATH_OPTIONS = (
    "segments",
    "vertical_line",
    "arc_straight",
    "maze",
    "lines",
    "random",
    "moon",
    "",
    ONE_PATH,
    Track(Path([[1, 1], [1, 6]])),
    [ONE_PATH],
    [ONE_PATH, Path([[0, 0], [1, 1]])],
    [],
    (ONE_PATH,),
    path_set("vertical_line"),
    path_set("random"),
    7,
    [7],
    None,
)
start_poses = st.one_of(
    st.lists(python_reals, min_size=0, max_size=4),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-100, 100)),
    st.sampled_from(("abc", None, 1.0, {"x": 1}, np.zeros((3, 1)))),
)


@st.composite
def reset_options(draw: Any, num_envs: int | None = None) -> Any:
    """None, a non-dict, or a dict of known and unknown keys with good and bad values; with
    ``num_envs``, also reset masks."""
    form = draw(st.sampled_from(("none", "dict", "dict", "dict", "not a dict")))
    if form == "none":
        return None
    if form == "not a dict":
        return draw(st.sampled_from(([], ["path"], "path", 7, ("path",))))
    keys = ["path", "start_pose", "goal", 1]
    if num_envs is not None:
        keys += ["reset_mask"] * 2
    options = {}
    for key in draw(st.sets(st.sampled_from(keys), max_size=3)):
        if key == "path":
            options[key] = draw(st.sampled_from(PATH_OPTIONS))
        elif key == "start_pose":
            options[key] = draw(start_poses)
        elif key == "reset_mask" and num_envs is not None:
            options[key] = draw(
                st.one_of(
                    hnp.arrays(bool, num_envs),
                    hnp.arrays(bool, num_envs + 1),
                    hnp.arrays(np.int8, num_envs, elements=st.integers(0, 1)),
                    st.sampled_from(("yes", None, [True] * num_envs, [[True], [False]])),
                )
            )
        else:
            options[key] = 1
    return options


def seeds(num_envs: int) -> Any:
    bad = st.one_of(st.floats(), st.booleans(), st.integers(-5, -1), st.text(max_size=2))
    good = st.one_of(st.none(), st.integers(0, 2**70), st.sampled_from((np.int64(3), np.uint8(7))))
    lists = st.lists(st.one_of(good, bad), min_size=num_envs - 1, max_size=num_envs + 1)
    return st.one_of(good, bad, lists)


def expected_start(options: Any) -> tuple[Path | None, np.ndarray | None]:
    """The path and start pose a valid option asks for (None: drawn as usual)."""
    if not isinstance(options, dict):
        return None, None
    requested = options.get("path")
    if isinstance(requested, str):
        path = path_set(requested).tracks[0].path
    elif isinstance(requested, Track):
        path = requested.path
    elif isinstance(requested, (list, tuple)):
        path = requested[0]
    elif requested is not None and hasattr(requested, "tracks"):
        path = requested.tracks[0].path
    else:
        path = requested
    pose = options.get("start_pose")
    return path, None if pose is None else np.asarray(pose, dtype=np.float64)


OPTION_WORDS = ("reset option", "path", "start_pose", "reset_mask", "seed")


def check_reset(env: Any, seed: Any, options: Any) -> None:
    """Reset with ``seed`` and ``options``: a ValueError naming them, or an episode that starts
    where they say and runs cleanly."""
    env.reset(seed=0)
    try:
        env.reset(seed=seed, options=options)
    except ValueError as error:
        assert any(word in str(error) for word in OPTION_WORDS), str(error)
        record("reset refused (ValueError)")
        return
    path, pose = expected_start(options)
    if isinstance(env, PathFollowingVectorEnv):
        mask = options.get("reset_mask") if isinstance(options, dict) else None
        restarted = np.arange(env.num_envs) if mask is None else np.flatnonzero(mask)
        paths, poses = env.paths, env.poses
    else:
        restarted, paths, poses = [0], [env.path], env.pose[np.newaxis]
    for robot in restarted:
        if path is not None:
            assert paths[robot] is path
        if pose is not None:
            np.testing.assert_array_equal(poses[robot, :2], pose[:2])
            assert poses[robot, 2] == wrap_angle(pose[2])
    record("reset ran")
    assert_clean_run_from_here(env)


def assert_clean_run_from_here(env: Any, steps: int = 3) -> None:
    rng = np.random.default_rng(0)
    for _ in range(steps):
        actions = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        observations, rewards, terminated, truncated, info = env.step(actions)
        assert np.isfinite(observations).all() and np.abs(observations).max() <= 1.0
        assert np.isfinite(np.asarray(rewards, dtype=np.float64)).all()
        assert_finite_step_info(info)
        if np.any(np.asarray(terminated) | np.asarray(truncated)):
            return


_RESET_SINGLE = PathFollowingEnv("diff_drive", "lines")
_RESET_VECTOR = PathFollowingVectorEnv(3, "constant_velocity", "random", start_noise=(0.2, 0.3))


@pytest.mark.parametrize("seed", [np.array(5), np.array([5]), np.array([[1, 2, 3]])])
def test_a_seed_in_an_array_of_the_wrong_shape_is_refused_by_name(seed):
    """Issue 30: reset(seed=np.array(5)) gave the vector env a raw TypeError."""
    for env in (_RESET_SINGLE, _RESET_VECTOR):
        with pytest.raises(ValueError, match="seed"):
            env.reset(seed=seed)


@CI
@given(reset_options(), st.one_of(st.none(), st.integers(0, 2**40)))
def test_single_env_reset_options_start_where_they_say_or_are_refused_by_name(options, seed):
    check_reset(_RESET_SINGLE, seed, options)


@CI
@given(reset_options(num_envs=3), seeds(3))
def test_vector_env_reset_options_and_seeds_start_where_they_say_or_are_refused(options, seed):
    check_reset(_RESET_VECTOR, seed, options)


# ---------------------------------------------------------------------------------------------
# MPPI's parameters

MPPI_FLAGS = ("primitives", "regenerate_noise", "smoothing")
#: Counts fuzzed with small values only: a valid huge one plans that many samples.
MPPI_COUNTS = ("samples", "horizon", "manoeuvres", "seed")
MPPI_NUMBERS = tuple(
    name
    for name in inspect.signature(MPPI).parameters
    if name not in MPPI_FLAGS and name not in MPPI_COUNTS
)
mppi_counts = st.one_of(
    st.integers(-3, 12),
    st.sampled_from((2.0, 3.5, math.nan, math.inf, True, None, "8", np.int8(4), 10**25)),
)
_MPPI_ENV = PathFollowingVectorEnv(2, "bicycle", "random", start_noise=(0.2, 0.3))


@st.composite
def mppi_arguments(draw: Any) -> dict[str, Any]:
    """MPPI's arguments with one to three of them fuzzed (the counts small)."""
    fuzzed = draw(
        st.sets(st.sampled_from((*MPPI_NUMBERS, *MPPI_FLAGS, *MPPI_COUNTS)), min_size=1, max_size=3)
    )
    arguments: dict[str, Any] = {"samples": 16, "horizon": 5, "manoeuvres": 4}
    for name in fuzzed:
        if name in MPPI_FLAGS:
            arguments[name] = draw(st.sampled_from((True, False, np.True_, 1, 0, "yes", None)))
        elif name in MPPI_COUNTS:
            arguments[name] = draw(mppi_counts)
        else:
            arguments[name] = draw(setting_values)
    return {"arguments": arguments, "names": fuzzed}


@CI
@given(mppi_arguments())
def test_mppi_parameters_plan_cleanly_or_are_refused_by_name(case):
    """Bad parameters raise a ValueError naming one of them; good ones plan finite actions
    within [-1, 1] for a few steps of two robots on random tracks."""
    try:
        bound = MPPI(**case["arguments"]).bind(_MPPI_ENV)  # a delay must fit the env's dt
    except ValueError as error:
        named = sorted(name for name in case["names"] if name in str(error))
        assert named, f"{error} names none of {case['names']}"
        record("MPPI refused (ValueError)")
        return
    observations, _ = _MPPI_ENV.reset(seed=0)
    for _ in range(3):
        actions, _ = bound.predict(observations)
        assert np.isfinite(actions).all() and np.abs(actions).max() <= 1.0
        observations, *_ = _MPPI_ENV.step(actions)
    record("MPPI planned")


# ---------------------------------------------------------------------------------------------
# Localization settings and the randomized localization's variants


def localization_settings(name: str) -> tuple[str, ...]:
    """The settings ``localization_params`` takes for the localization ``name``."""
    return tuple(inspect.signature(LOCALIZATIONS[name]).parameters)


localization_values = st.one_of(
    setting_values,
    # Values a setting may well take, so that half the examples are worth running.
    st.floats(1e-4, 10.0),
    st.integers(3, 70_000),
    st.sampled_from(("exact", "euler", "midpoint", 65535, None, (0.1, 0.0), [[0, 0], [9, 0]])),
    st.lists(st.lists(st.floats(-20, 20), min_size=2, max_size=2), min_size=0, max_size=5),
)
LOCALIZATION_NAMES = ("odometry", "beacons", "odometry+beacons", "randomized", "exact", "gps", 3)
#: The names drawn, the real localizations three times as often as the others.
DRAWN_LOCALIZATIONS = st.sampled_from((*LOCALIZATION_NAMES[:4] * 3, *LOCALIZATION_NAMES[4:]))


@st.composite
def localization_params(draw: Any, name: Any, depth: int = 0) -> dict[str, Any]:
    """One to three settings of localization ``name`` (and unknown ones), fuzzed; for
    ``"randomized"``, a list of variants, each a localization and its fuzzed settings."""
    if name == "randomized" and depth == 0:
        variants = draw(
            st.lists(
                st.one_of(
                    DRAWN_LOCALIZATIONS.flatmap(
                        lambda inner: localization_params(inner, depth=1).map(
                            lambda params: {"localization": inner, **params}
                        )
                    ),
                    st.sampled_from(({}, "odometry", None, {"k_distance": 1e-3})),
                ),
                max_size=3,
            )
        )
        return {"variants": draw(st.sampled_from((variants, variants, "x", {"a": 1})))}
    known = localization_settings(name) if isinstance(name, str) and name in LOCALIZATIONS else ()
    keys = draw(st.sets(st.sampled_from(known), max_size=2)) if known else set()
    if not known or draw(st.integers(0, 4)) == 0:
        keys.add("bogus")
    return {key: draw(localization_values) for key in keys}


@st.composite
def localization_arguments(draw: Any) -> dict[str, Any]:
    """A single env's arguments with a localization and fuzzed ``localization_params``."""
    name = draw(DRAWN_LOCALIZATIONS)
    params = draw(localization_params(name))
    names = {"localization", "localization_params", *params}
    if name == "randomized" and isinstance(params.get("variants"), list):
        for variant in params["variants"]:
            if isinstance(variant, dict):
                names |= {key for key in variant if key != "localization"}
        names.add("variants")
    return {
        "kind": "single",
        "model": draw(st.sampled_from(tuple(MODELS))),
        "paths": draw(st.sampled_from(("segments", "arc_straight", "maze", "random"))),
        "settings": {"localization": name, "localization_params": params},
        "weights": None,
        "names": names,
    }


@settings(CI, max_examples=120)
@given(localization_arguments())
@example(
    {
        "kind": "single",
        "model": "diff_drive",
        "paths": "segments",
        "settings": {"localization": "beacons", "localization_params": {"head_offset": "x"}},
        "weights": None,
        "names": {"head_offset"},  # issue 30: the error said "offset"
    }
)
@example(
    {
        "kind": "single",
        "model": "diff_drive",
        "paths": "segments",
        "settings": {
            "localization": "beacons",
            # Two reflectors at one point divided by zero in the fix's weights.
            "localization_params": {"reflectors": [[0, 0], [0, 0], [14, 0], [0, 14], [14, 14]]},
        },
        "weights": None,
        "names": {"reflectors"},
    }
)
def test_localization_settings_run_cleanly_or_are_refused_by_name(arguments):
    check_constructor(arguments)


#: The localization settings that are numbers (issue 30: beyond float64 each raised an
#: OverflowError, through localization_params, --env-kwargs and a YAML's env_kwargs alike).
NUMERIC_LOCALIZATION_SETTINGS = tuple(
    name
    for name in localization_settings("odometry+beacons")
    if name not in ("method", "reflectors", "head_offset")
)
#: Limits, where a number beyond float64 is no limit at all.
UNLIMITED_BY_HUGE = ("max_range", "max_heading_gain")
HUGE_LOCALIZED_ID = "mobile_envs/Tricycle-Segments-v0"


def huge_localization_kwargs(name: str, sign: int) -> dict[str, Any]:
    settings_ = {name: sign * 10**400}
    if name == "encoder_counts":
        settings_["traction_wheel_radius"] = 0.1
    return {"localization": "odometry+beacons", "localization_params": settings_}


@pytest.mark.parametrize("sign", [1, -1], ids=["10**400", "-10**400"])
@pytest.mark.parametrize("name", NUMERIC_LOCALIZATION_SETTINGS)
def test_a_localization_setting_beyond_float64_is_refused_by_name(name, sign):
    kwargs = huge_localization_kwargs(name, sign)
    if sign > 0 and name in UNLIMITED_BY_HUGE:
        env = gym.make(HUGE_LOCALIZED_ID, **kwargs)
        assert_clean_run(env.unwrapped)
        return
    with pytest.raises(ValueError, match=f"{name} must"):
        gym.make(HUGE_LOCALIZED_ID, **kwargs)


@pytest.mark.parametrize("name", ["k_distance", "encoder_counts", "frequency", "max_readings"])
def test_train_py_names_a_localization_setting_beyond_float64_in_env_kwargs(name, capsys):
    pytest.importorskip("yaml", reason="train.py reads YAML (the train extra)")
    import train

    env_kwargs = json.dumps(huge_localization_kwargs(name, 1))
    command = ["evaluate", "--model", "unused.zip", "--env", HUGE_LOCALIZED_ID]
    assert train.main([*command, "--env-kwargs", env_kwargs]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "--env-kwargs" in lines[0] and f"{name} must" in lines[0]


def test_train_py_names_a_localization_setting_beyond_float64_in_a_yaml_env_kwargs(
    tmp_path, capsys
):
    yaml = pytest.importorskip("yaml", reason="train.py reads YAML (the train extra)")
    pytest.importorskip("stable_baselines3", reason="training needs the train extra")
    import train

    entry = {
        "n_steps": 64,
        "batch_size": 64,
        "env_kwargs": huge_localization_kwargs("k_heading", 1),
    }
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump({"default": entry}))
    command = ["--env", HUGE_LOCALIZED_ID, "--hyperparams", str(hyperparams), "--n-envs", "2"]
    output = ["--output", str(tmp_path / "run"), "--eval-freq", "0", "--no-progress"]
    assert train.main([*command, *output, "--timesteps", "128"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "k_heading must" in lines[0]


# ---------------------------------------------------------------------------------------------
# The classical agents' parameters

#: Each agent with the arguments it needs, and its numeric parameters (23 in all).
AGENT_PARAMETERS = {
    PurePursuit: ({}, ("lookahead", "speed", "max_angular_speed")),
    RegulatedPurePursuit: (
        {},
        tuple(inspect.signature(RegulatedPurePursuit).parameters),
    ),
    TricycleGuidance: ({"a": 1.0, "b": 1.0}, ("a", "b", "speed", "c")),
}


def below_overflow(value: Any) -> bool:
    """Whether ``value`` is no real beyond 1e306 in magnitude. Gains and speeds beyond it
    overflow the laws' own arithmetic (TricycleGuidance with a = c = 1.8e308 commands NaN:
    inf - inf), so an agent's commands are only checked below them."""
    if isinstance(value, bool) or not isinstance(value, REAL_TYPES):
        return True
    try:
        return abs(float(value)) <= 1e306
    except OverflowError:  # an int beyond float64, refused by name
        return True


@st.composite
def agent_arguments(draw: Any) -> tuple[type, dict[str, Any]]:
    agent = draw(st.sampled_from(tuple(AGENT_PARAMETERS)))
    required, numeric = AGENT_PARAMETERS[agent]
    fuzzed = draw(st.sets(st.sampled_from(numeric), min_size=1, max_size=3))
    return agent, {
        **required,
        **{name: draw(setting_values.filter(below_overflow)) for name in fuzzed},
    }


def test_the_agents_have_23_numeric_parameters():
    assert sum(len(numeric) for _, numeric in AGENT_PARAMETERS.values()) == 23


def check_agent(agent: type, parameters: dict[str, Any]) -> None:
    """Build the agent: one that drives a few steps, or a ValueError naming a parameter."""
    try:
        built = agent(**parameters)
    except ValueError as error:
        assert any(name in str(error) for name in parameters), str(error)
        record("agent refused (ValueError)")
        return
    model = "tricycle" if agent is TricycleGuidance else "diff_drive"
    env = PathFollowingEnv(model, "segments")
    bound = built.bind(env)
    observation, _ = env.reset(seed=0)
    for _ in range(3):
        action, _ = bound.predict(observation)
        assert np.isfinite(action).all()
        observation = env.step(action)[0]
    record("agent ran")


@CI
@given(agent_arguments())
def test_agent_parameters_drive_or_are_refused_by_name(arguments):
    check_agent(*arguments)


@pytest.mark.parametrize("sign", [1, -1], ids=["10**400", "-10**400"])
@pytest.mark.parametrize(
    ("agent", "name"),
    [(agent, name) for agent, (_, numeric) in AGENT_PARAMETERS.items() for name in numeric],
)
def test_an_agent_parameter_beyond_float64_is_refused_by_name(agent, name, sign):
    required, _ = AGENT_PARAMETERS[agent]
    with pytest.raises(ValueError, match=f"^{name} must"):
        agent(**{**required, name: sign * 10**400})


@pytest.mark.parametrize("model_name", ["diff_drive", "mecanum"])
@pytest.mark.parametrize("speed", [1e308, -1e308])
def test_the_twist_bridge_saturates_a_speed_near_float_max(model_name, speed):
    # Divided by the wheel radius before they were saturated, such speeds became inf wheel
    # speeds and NaN after saturation; the bridge asks for the top speed instead.
    model = MODELS[model_name](max_wheel_speed=20.0)
    inputs = model.inputs_for(np.zeros(model.state_dim), speed, 0.0, 0.1)
    assert np.isfinite(inputs).all()
    np.testing.assert_allclose(inputs, np.sign(speed) * 20.0, rtol=1e-12)


triangulation_numbers = st.one_of(
    st.floats(-50, 50), st.sampled_from((math.nan, math.inf, 0.0, 1e300, -1e-300))
)


@st.composite
def triangulation_inputs(draw: Any) -> tuple[Any, Any, Any, dict[str, Any]]:
    """Reflectors, bearings, a heading estimate and options as a control loop might pass
    them: mostly well formed, with bad values and shapes among them."""
    count = draw(st.integers(2, 6))
    # Distinct coordinates: hypothesis's arrays otherwise repeat a few values, mostly on a line.
    well_formed = hnp.arrays(np.float64, (count, 2), elements=st.floats(-30, 30), unique=True)
    reflectors = draw(
        st.one_of(
            well_formed,
            well_formed,
            well_formed,
            hnp.arrays(np.float64, (count, 2), elements=triangulation_numbers),
            st.sampled_from(([[0, 0], [1, 1], [2, 2]], [[0, 0]], "abc", None)),
        )
    )
    rows = len(reflectors) if isinstance(reflectors, (list, np.ndarray)) else 3
    drawn_bearings = hnp.arrays(np.float64, (rows,), elements=st.floats(-7, 7), fill=st.nothing())
    bearings = draw(
        st.one_of(
            drawn_bearings,
            drawn_bearings,
            hnp.arrays(np.float64, (rows,), elements=triangulation_numbers),
            st.just(np.full(rows, 0.3)),  # every line parallel: issue 30, item 2
            hnp.arrays(np.float64, (rows + 1,), elements=st.floats(-7, 7)),
        )
    )
    estimate = draw(
        st.one_of(st.floats(-7, 7), st.floats(-7, 7), st.sampled_from((math.nan, "x", [0.1, 0.2])))
    )
    options = draw(
        st.fixed_dictionaries(
            {},
            optional={
                "bearing_error": st.one_of(st.floats(0, 0.1), triangulation_numbers),
                "max_heading_gain": st.one_of(st.floats(1, 1e3), triangulation_numbers),
                "position_estimate": st.one_of(
                    st.tuples(st.floats(-9, 9), st.floats(-9, 9)), st.just((math.nan, 0.0))
                ),
            },
        )
    )
    return reflectors, bearings, estimate, options


TRIANGULATION_ARGUMENTS = (
    "reflectors",
    "bearings",
    "heading_estimate",
    "bearing_error",
    "max_heading_gain",
    "position_estimate",
)


@settings(CI, max_examples=300)
@given(triangulation_inputs())
def test_triangulation_gives_a_finite_flagged_fix_or_names_the_bad_input(inputs):
    check_triangulation(inputs)


def check_triangulation(inputs: tuple[Any, Any, Any, dict[str, Any]]) -> None:
    """Whatever bearings a sweep reads, a fix is finite and flagged (issue 30, item 2: bearings
    no pose gives raised); only invalid input raises, a ValueError naming it."""
    reflectors, bearings, estimate, options = inputs
    try:
        fix = triangulate(reflectors, bearings, estimate, **options)
    except ValueError as error:
        assert any(name in str(error) for name in TRIANGULATION_ARGUMENTS), str(error)
        record("triangulation refused (ValueError)")
        return
    assert all(math.isfinite(value) for value in fix[:3]), fix
    assert fix.status in (FIX, HEADING_KEPT, NO_FIX)
    record(f"triangulation {('fixed', 'kept the heading', 'held the estimate')[fix.status]}")


# ---------------------------------------------------------------------------------------------
# The sweep and grid command lines: every setting checked before anything trains

SWEEP_FLAGS = {
    "--trials": st.sampled_from(("2", "0", "-1", "x", "1.5", "\u00b2", "")),
    "--timesteps": st.sampled_from(("512", "0", "-5", "1e3", "10" * 30)),
    "--n-envs": st.sampled_from(("2", "0", "-1", "two")),
    "--seed": st.sampled_from(("0", "-1", str(2**32), "3", "\u0663")),
    "--eval-seed": st.sampled_from(("7", "-5", str(2**40))),
    "--eval-episodes": st.sampled_from(("1", "0", "nan")),
    "--eval-freq": st.sampled_from(("0", "256", "-1")),
    "--heartbeat": st.sampled_from(("1", "0", "inf")),
    "--sampler-seed": st.sampled_from(("1", "-3", "seed")),
    "--storage": st.sampled_from(("foo://x", "mysql://u@h/db", "sqlite:///{out}/s.db", "{out}/j")),
    "--env": st.sampled_from(("mobile_envs/DiffDrive-Lines-v0", "mobile_envs/Nope-v0", "")),
    "--objective": st.sampled_from(("completion_rate", "speed", "mean_abs_cte")),
}
GRID_FLAGS = {
    "--seeds": st.sampled_from(("0-1", "3", "1-0", "\u00b2", "0,0", "-1", "a-b", str(2**33))),
    "--episodes": st.sampled_from(("1", "0", "-2", "x")),
    "--eval-seed": st.sampled_from(("0", "-5", "nan")),
    "--eval-env-kwargs": st.sampled_from(
        ('{"dt": 0.05}', '{"dt": -1}', "[1, 2]", "{", '{"bogus": 1}', '{"start_noise": "x"}')
    ),
    "--eval-paths": st.sampled_from(("Lines", "Moon", "Maze")),
    "--timesteps": st.sampled_from(("256", "0", "-3")),
    "--workers": st.sampled_from(("1", "0", "many")),
    "--retries": st.sampled_from(("0", "-1")),
    "--checkpoint-freq": st.sampled_from(("0", "-4", "128")),
    "--ray-timeout": st.sampled_from(("5", "0")),
    "--algos": st.sampled_from(("ppo", "a2c")),
}


@st.composite
def command_lines(draw: Any, flags: dict[str, Any]) -> tuple[list[str], set[str]]:
    """One to three of ``flags`` with fuzzed values; the flags an error may name."""
    chosen = draw(st.sets(st.sampled_from(sorted(flags)), min_size=1, max_size=3))
    argv: list[str] = []
    for flag in sorted(chosen):
        argv += [flag, draw(flags[flag])]
    return argv, chosen


def check_command_line(command: str, argv: list[str], named: set[str], tmp: Any) -> None:
    """The settings are refused (exit status 2, one error line naming a fuzzed flag or the
    value it gave) or all checked, before anything trains."""
    import contextlib
    import io

    import yaml

    from agents.grid import grid
    from agents.sweeps import sweep

    hyperparams = tmp / "ppo.yml"
    hyperparams.write_text(yaml.safe_dump(TINY_PPO))
    space = tmp / "space.yml"
    rate = {"type": "float", "low": 1e-4, "high": 1e-2, "log": True}
    space.write_text(yaml.safe_dump({"ppo": {"learning_rate": rate}}))
    output = tmp / "out"
    argv = [part.replace("{out}", str(output)) for part in argv]
    base = ["--output", str(output), "--hyperparams", str(hyperparams)]
    if command == "sweep":
        base += ["--search-space", str(space)]
    stderr = io.StringIO()
    try:
        with contextlib.redirect_stderr(stderr):
            if command == "sweep":
                args = sweep.parse_args([*base, *argv])
                sweep.settings_from_args(args)
            else:
                args = grid.parse_args([*base, *argv])
                grid.specs_from_args(args)
    except SystemExit as exit:  # argparse's refusal
        assert exit.code == 2
        message = stderr.getvalue().strip().splitlines()[-1]
    except ValueError as error:
        message = str(error)
    else:
        assert not (output / "trials").exists() and not (output / "runs").exists()
        record(f"{command} settings checked")
        return
    values = {value for value in argv if not value.startswith("--")}
    assert any(name in message for name in named) or any(
        value and value in message for value in values
    ), (argv, message)
    record(f"{command} settings refused")


@settings(CI, max_examples=25)
@given(command_lines(SWEEP_FLAGS))
def test_sweep_settings_are_checked_or_refused_by_name_before_training(tmp_path_factory, line):
    pytest.importorskip("optuna", reason="sweeps need the sweep extra")
    check_command_line("sweep", *line, tmp_path_factory.mktemp("sweep"))


@settings(CI, max_examples=25)
@given(command_lines(GRID_FLAGS))
def test_grid_settings_are_checked_or_refused_by_name_before_training(tmp_path_factory, line):
    pytest.importorskip("scipy", reason="the grid needs the sweep extra")
    check_command_line("grid", *line, tmp_path_factory.mktemp("grid"))
