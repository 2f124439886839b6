"""Catalogues: things chosen by name, which user code extends without editing the package
(path sets, sensors, localizations), and the env ids made from them."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mobile_envs.catalogue import Catalogue
from mobile_envs.envs.registration import (
    env_specs,
    has_encoders,
    localization_ids,
    register_envs,
)
from mobile_envs.robots.model import MODELS
from mobile_envs.sensing.beacons import default_reflectors
from mobile_envs.sensing.localization import (
    LOCALIZATIONS,
    Localization,
    make_localization,
    register_localization,
)
from mobile_envs.tracks import (
    PATH_SETS,
    FixedPathSet,
    MixedPathSet,
    Track,
    path_set,
    path_set_names,
    register_path_set,
)
from mobile_envs.tracks.arc_straight import LAB_REFLECTORS
from mobile_envs.tracks.course import OPEN_AREA_REFLECTORS
from mobile_envs.tracks.mazes import grid_posts, maze_reflectors
from mobile_envs.world.paths import Path


def shape_area(side: float = 1.0, *, squared: bool = True) -> float:
    return side * side if squared else side


def test_a_catalogue_is_a_read_only_mapping_in_name_order():
    shapes = Catalogue("shape")
    shapes.register("square", shape_area)
    shapes.register("line", abs)
    assert sorted(shapes) == list(shapes) == ["line", "square"] == list(shapes.names())
    assert "square" in shapes and "circle" not in shapes and len(shapes) == 2
    assert shapes["square"] is shape_area
    assert not hasattr(shapes, "__setitem__")


def test_a_duplicate_name_is_refused_unless_replaced():
    shapes = Catalogue("shape")
    shapes.register("square", shape_area)
    with pytest.raises(ValueError, match=r"shape 'square' is already registered.*replace=True"):
        shapes.register("square", abs)
    shapes.register("square", abs, replace=True)
    assert shapes["square"] is abs


@pytest.mark.parametrize(
    ("name", "factory", "message"),
    [("", abs, "non-empty string"), (3, abs, "non-empty string"), ("x", 3, "callable")],
)
def test_bad_registrations_are_refused(name, factory, message):
    with pytest.raises(ValueError, match=message):
        Catalogue("shape").register(name, factory)


def test_make_builds_from_settings_and_names_what_is_wrong():
    shapes = Catalogue("shape")
    shapes.register("square", shape_area)
    assert shapes.make("square") == 1.0
    assert shapes.make("square", {"side": 3.0, "squared": False}) == 3.0
    assert shapes.settings_of("square") == ("side", "squared")
    with pytest.raises(ValueError, match=r"unknown shape 'circle'; known: \['square'\]"):
        shapes.make("circle")
    with pytest.raises(
        ValueError,
        match=r"params \['radius'\] are not settings of shape 'square'; its settings: "
        r"\['side', 'squared'\]",
    ):
        shapes.make("square", {"radius": 1.0, "side": 2.0}, label="params")
    with pytest.raises(ValueError, match="settings of shape 'square' must be a mapping"):
        shapes.make("square", [("side", 2.0)])


def test_make_passes_any_setting_to_a_factory_that_takes_any():
    def anything(**settings):
        return settings

    catalogue = Catalogue("thing")
    catalogue.register("anything", anything)
    assert catalogue.make("anything", {"a": 1}) == {"a": 1}


# ---------------------------------------------------------------- path sets


def test_the_built_in_path_sets_are_catalogued_with_their_ids():
    assert set(PATH_SETS) == set(path_set_names())
    ids = {name: entry.env_id for name, entry in PATH_SETS.items() if entry.env_id}
    assert ids["lines"] == "Lines" and ids["training"] == "Random"
    assert ids["arc_straight"] == "ArcStraight" and "random_maze" not in ids
    assert PATH_SETS["arc_straight"].env_models == ("tricycle",)
    assert PATH_SETS["training"].env_localizations == ()


def test_each_set_carries_its_reflector_layout():
    np.testing.assert_array_equal(path_set("segments").reflectors, OPEN_AREA_REFLECTORS)
    np.testing.assert_array_equal(path_set("random").reflectors, OPEN_AREA_REFLECTORS)
    np.testing.assert_array_equal(path_set("arc_straight").reflectors, LAB_REFLECTORS)
    posts = maze_reflectors(path_set("maze").tracks[0].maze)
    np.testing.assert_array_equal(path_set("maze").reflectors, posts)
    np.testing.assert_array_equal(path_set("random_maze").reflectors, posts)
    # 8 x 8 cells of 1.5 m: 81 posts at every multiple of 1.5 m in [0, 12], by brute force.
    expected = {(1.5 * i, 1.5 * j) for i in range(9) for j in range(9)}
    assert {tuple(post) for post in posts.tolist()} == expected and len(posts) == 81
    # The training mix: both layouts, the open area's first.
    np.testing.assert_array_equal(
        path_set("training").reflectors, np.vstack((OPEN_AREA_REFLECTORS, posts))
    )
    assert not path_set("lines").reflectors.flags.writeable


def test_a_mix_carries_each_distinct_layout_once_and_none_if_a_member_has_none():
    lines, segments = path_set("lines"), path_set("segments")
    np.testing.assert_array_equal(
        MixedPathSet([lines, segments], [1, 1]).reflectors, OPEN_AREA_REFLECTORS
    )
    bare = FixedPathSet("bare", [Track(Path([[0, 0], [3, 0]]))])
    assert bare.reflectors is None
    assert MixedPathSet([lines, bare], [1, 1]).reflectors is None


@pytest.mark.parametrize("reflectors", [[[0, 0, 0]], [[0, np.nan]], "posts"])
def test_a_bad_layout_is_refused(reflectors):
    with pytest.raises(ValueError, match="path set 'bare': reflectors must be"):
        FixedPathSet("bare", [Track(Path([[0, 0], [3, 0]]))], reflectors)


def test_default_reflectors_reads_the_set_and_names_a_set_without_a_layout():
    np.testing.assert_array_equal(default_reflectors("maze"), path_set("maze").reflectors)
    np.testing.assert_array_equal(default_reflectors(path_set("lines")), OPEN_AREA_REFLECTORS)
    assert default_reflectors("lines").flags.writeable  # a new array
    bare = FixedPathSet("bare", [Track(Path([[0, 0], [3, 0]]))])
    with pytest.raises(ValueError, match="path_set_name 'bare' has no default reflector"):
        default_reflectors(bare)


def test_a_grid_of_posts_is_every_corner_of_its_cells():
    posts = grid_posts(2, 3, 0.5, (1.0, -1.0))
    expected = {(1.0 + 0.5 * col, -1.0 + 0.5 * row) for col in range(4) for row in range(3)}
    assert {tuple(post) for post in posts.tolist()} == expected and len(posts) == 12


@pytest.mark.parametrize("env_id", ["square", "Square-2", "", 3])
def test_a_path_set_id_must_be_camel_case(env_id):
    with pytest.raises(ValueError, match="env_id must be CamelCase"):
        register_path_set("never_registered", lambda: path_set("lines"), env_id=env_id)
    assert "never_registered" not in PATH_SETS


def test_the_ids_are_the_catalogues_facts():
    specs = env_specs()
    assert specs["mobile_envs/DiffDrive-Segments-v0"] == {
        "model": "diff_drive",
        "paths": "segments",
        "start_noise": 0.0,
    }
    assert specs["mobile_envs/Tricycle-ArcStraight-Beacons-v0"] == {
        "model": "tricycle",
        "paths": "arc_straight",
        "step_limit": 750,
        "localization": "beacons",
    }
    assert specs["mobile_envs/Bicycle-Random-v0"]["start_noise"] == (0.2, 0.3)
    assert "mobile_envs/Bicycle-Random-Odometry-v0" not in specs
    assert "mobile_envs/ConstantVelocity-Maze-Odometry-v0" not in specs
    assert localization_ids() == {
        "Odometry": "odometry",
        "Beacons": "beacons",
        "OdometryBeacons": "odometry+beacons",
    }
    assert register_envs() == ()  # import mobile_envs registered them all


def test_user_code_adds_a_path_set_with_ids_and_beacons_without_editing_the_package():
    """In a fresh process, as a user script would: register a set with its reflectors, get
    its ids (again: nothing), and drive its beacons id, which reads the set's layout; a set
    its builder names otherwise is refused."""
    script = textwrap.dedent(
        """
        import gymnasium as gym
        import numpy as np
        import mobile_envs
        from mobile_envs.tracks import FixedPathSet, Track, register_path_set
        from mobile_envs.world.paths import Path

        POSTS = [[-1.0, -1.0], [7.0, -1.0], [7.0, 5.0], [-1.0, 5.0]]

        def square():
            corners = [[1, 1], [5, 1], [5, 4], [1, 4], [1, 1.5]]
            return FixedPathSet("square", [Track(Path(corners))], POSTS)

        register_path_set("square", square, env_id="Square")
        added = mobile_envs.register_envs()
        assert mobile_envs.register_envs() == ()
        assert "mobile_envs/DiffDrive-Square-v0" in added
        assert "mobile_envs/ConstantVelocity-Square-Beacons-v0" in added
        assert "mobile_envs/ConstantVelocity-Square-Odometry-v0" not in added
        env = gym.make("mobile_envs/DiffDrive-Square-Beacons-v0")
        env.reset(seed=0)
        np.testing.assert_array_equal(env.unwrapped.core.localization.landmarks, POSTS)
        register_path_set("misnamed", lambda: FixedPathSet("other", square().tracks))
        try:
            gym.make("mobile_envs/PathFollowing-v0", paths="misnamed")
        except ValueError as error:
            assert "'misnamed' is built with another name, 'other'" in str(error), error
        else:
            raise AssertionError("a set built under another name was taken")
        print(len(added))
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    # Every model's id, its beacons id and its realistic-plant id, and the two odometry ids of
    # each model with encoders.
    with_encoders = sum(has_encoders(model) for model in MODELS.values())
    assert int(done.stdout) == 3 * len(MODELS) + 2 * with_encoders


# ---------------------------------------------------------------- localizations


class StandStill(Localization):
    """A test localization: the robot believes it is where it started."""

    def __init__(self, drift: float = 0.0):
        self.drift = drift

    def reset(self, world, indices, rngs, estimate):
        estimate[indices] = world.state[indices, :3]

    def update(self, world, indices, rngs, estimate):
        estimate[indices, 0] += self.drift


def test_user_code_registers_a_localization_by_name():
    register_localization("test_stand_still", StandStill, replace=True)
    built = make_localization("test_stand_still", {"drift": 0.5})
    assert isinstance(built, StandStill) and built.drift == 0.5
    with pytest.raises(ValueError, match=r"localization_params \['speed'\] are not settings"):
        make_localization("test_stand_still", {"speed": 1.0})
    with pytest.raises(ValueError, match="already registered"):
        register_localization("test_stand_still", StandStill)
    with pytest.raises(ValueError, match='"exact" is the robot knowing its pose'):
        register_localization("exact", StandStill)
    assert (
        "test_stand_still" in LOCALIZATIONS
        and "test_stand_still" not in localization_ids().values()
    )
