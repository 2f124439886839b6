"""Gymnasium environments in which a wheeled robot follows a path.

``import mobile_envs`` registers the environment ids, nothing else::

    import gymnasium as gym
    import mobile_envs

    env = gym.make("mobile_envs/DiffDrive-Segments-v0")

Ids: ``mobile_envs/{ConstantVelocity,DiffDrive,Bicycle,Tricycle}-{Lines,Segments,
SharpSegments,Maze,Random}-v0``, ``mobile_envs/Tricycle-ArcStraight-v0`` (the run of
Font-Llagunes & Batlle 2006) and ``mobile_envs/PathFollowing-v0``, which takes
:class:`mobile_envs.envs.path_following.PathFollowingEnv`'s keyword arguments. ``gym.make_vec(id,
num_envs=N)`` returns the batched :class:`mobile_envs.envs.vector.PathFollowingVectorEnv`.

Robots that localize (:mod:`mobile_envs.sensing.modes`): ``mobile_envs/{DiffDrive,Bicycle,
Tricycle}-{Lines,Segments,SharpSegments,Maze}-{Odometry,OdometryBeacons}-v0``,
``mobile_envs/{ConstantVelocity,DiffDrive,Bicycle,Tricycle}-{Lines,Segments,SharpSegments,
Maze}-Beacons-v0`` and ``mobile_envs/Tricycle-ArcStraight-Beacons-v0`` (Font-Llagunes & Batlle's run
on their laser positioning). Robots that do not do exactly what they are told
(:mod:`mobile_envs.sim.plant`):
``mobile_envs/<Model>-{Lines,Segments,SharpSegments,Maze}-Realistic-v0``.
"""

from gymnasium.envs.registration import register

# Before any kernel module loads: numba would otherwise reuse kernels compiled from sources
# that have changed since (it checks only each kernel's own file, not what the kernel inlines).
from mobile_envs._kernels import kernel_cache  # noqa: F401
from mobile_envs.robots import MODELS

#: Model names per id prefix; every model class names its own (``KinematicModel.env_id``).
MODEL_IDS = {model.env_id: name for name, model in MODELS.items()}
#: Path sets per id suffix, with the start noise each trains or evaluates with.
PATH_SET_IDS = {
    "Lines": ("lines", 0.0),
    "Segments": ("segments", 0.0),
    "SharpSegments": ("sharp_segments", 0.0),
    "Maze": ("maze", 0.0),
    "Random": ("training", (0.2, 0.3)),
}
#: Localizations per id suffix, and whether they count wheels (the constant-velocity model
#: has none).
LOCALIZATION_IDS = {
    "Odometry": ("odometry", True),
    "Beacons": ("beacons", False),
    "OdometryBeacons": ("odometry+beacons", True),
}
#: The path sets that have localized ids, and ids with a realistic plant.
LOCALIZED_PATH_SETS = ("Lines", "Segments", "SharpSegments", "Maze")
#: Plants per id suffix (mobile_envs.sim.plant's presets).
PLANT_IDS = {"Realistic": "realistic"}
ENTRY_POINT = "mobile_envs.envs.path_following:PathFollowingEnv"
VECTOR_ENTRY_POINT = "mobile_envs.envs.vector:PathFollowingVectorEnv"


def _register_all() -> None:
    for model_id, model in MODEL_IDS.items():
        for set_id, (paths, start_noise) in PATH_SET_IDS.items():
            register(
                id=f"mobile_envs/{model_id}-{set_id}-v0",
                entry_point=ENTRY_POINT,
                vector_entry_point=VECTOR_ENTRY_POINT,
                kwargs={"model": model, "paths": paths, "start_noise": start_noise},
            )
    register(
        id="mobile_envs/Tricycle-ArcStraight-v0",
        entry_point=ENTRY_POINT,
        vector_entry_point=VECTOR_ENTRY_POINT,
        # Seed 003 drove this run at 0.2 m/s, a third of the nominal speed that sets the
        # default time limit: allow three traversals at 0.2 m/s.
        kwargs={"model": "tricycle", "paths": "arc_straight", "step_limit": 750},
    )
    _register_localized()
    _register_plants()
    register(
        id="mobile_envs/PathFollowing-v0",
        entry_point=ENTRY_POINT,
        vector_entry_point=VECTOR_ENTRY_POINT,
    )


def _register_localized() -> None:
    for model_id, model in MODEL_IDS.items():
        wheeled = MODELS[model].has_encoders
        for suffix, (localization, needs_wheels) in LOCALIZATION_IDS.items():
            if needs_wheels and not wheeled:
                continue
            for set_id in LOCALIZED_PATH_SETS:
                paths, start_noise = PATH_SET_IDS[set_id]
                register(
                    id=f"mobile_envs/{model_id}-{set_id}-{suffix}-v0",
                    entry_point=ENTRY_POINT,
                    vector_entry_point=VECTOR_ENTRY_POINT,
                    kwargs={
                        "model": model,
                        "paths": paths,
                        "start_noise": start_noise,
                        "localization": localization,
                    },
                )
    register(
        id="mobile_envs/Tricycle-ArcStraight-Beacons-v0",
        entry_point=ENTRY_POINT,
        vector_entry_point=VECTOR_ENTRY_POINT,
        kwargs={
            "model": "tricycle",
            "paths": "arc_straight",
            "step_limit": 750,
            "localization": "beacons",
        },
    )


def _register_plants() -> None:
    for model_id, model in MODEL_IDS.items():
        for suffix, plant in PLANT_IDS.items():
            for set_id in LOCALIZED_PATH_SETS:
                paths, start_noise = PATH_SET_IDS[set_id]
                register(
                    id=f"mobile_envs/{model_id}-{set_id}-{suffix}-v0",
                    entry_point=ENTRY_POINT,
                    vector_entry_point=VECTOR_ENTRY_POINT,
                    kwargs={
                        "model": model,
                        "paths": paths,
                        "start_noise": start_noise,
                        "plant": plant,
                    },
                )


_register_all()
