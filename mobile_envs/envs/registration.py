"""The environment ids, made from the catalogues: every model (:data:`mobile_envs.robots.
model.MODELS`) on every path set that gives ids (:data:`mobile_envs.tracks.catalogue.
PATH_SETS`), with every localization that gives them
(:data:`mobile_envs.sensing.localization.LOCALIZATIONS`).

Ids: ``mobile_envs/<Model>-<PathSet>-v0`` and, where the path set has localized ids,
``mobile_envs/<Model>-<PathSet>-<Localization>-v0`` (a localization that counts wheel turns only for
models with wheel encoders) and ``mobile_envs/<Model>-<PathSet>-Realistic-v0`` (the plant's
``"realistic"`` preset, :mod:`mobile_envs.sim.plant`), and ``mobile_envs/PathFollowing-v0``, which
takes :class:`~mobile_envs.envs.path_following.PathFollowingEnv`'s keyword arguments. ``import
mobile_envs`` registers them; :func:`register_envs` registers those of models, path sets and
localizations added since.
"""

from __future__ import annotations

from typing import Any

from gymnasium.envs.registration import register, registry

from mobile_envs.robots.model import MODELS, KinematicModel
from mobile_envs.sensing.localization import LOCALIZATIONS
from mobile_envs.sim.plant import PRESET_IDS
from mobile_envs.tracks.catalogue import PATH_SETS, PathSetEntry

ENTRY_POINT = "mobile_envs.envs.path_following:PathFollowingEnv"
VECTOR_ENTRY_POINT = "mobile_envs.envs.vector:PathFollowingVectorEnv"
#: The id that takes every setting as a keyword argument.
GENERIC_ID = "mobile_envs/PathFollowing-v0"


def has_encoders(model: type[KinematicModel]) -> bool:
    """Whether ``model`` has the wheel (or steering) encoders odometry counts: the
    constant-velocity robot has none."""
    return model.has_encoders


def model_ids() -> dict[str, str]:
    """The models' id parts (``"DiffDrive"``), each with its model's name."""
    return {model.env_id: name for name, model in MODELS.items()}


def path_set_ids(*, compared: bool = False) -> dict[str, str]:
    """The id parts (``"Segments"``) of the path sets with ids for every model, each with its
    set's name.

    :param compared: only those ``train.py compare`` runs by default
    """
    return {
        entry.env_id: name
        for name, entry in PATH_SETS.items()
        if entry.env_id is not None
        and entry.env_models is None
        and (entry.compared or not compared)
    }


def localization_ids() -> dict[str, str]:
    """The localizations' id parts (``"Odometry"``), each with its localization's name."""
    ids = {}
    for name, factory in LOCALIZATIONS.items():
        env_id = getattr(factory, "env_id", None)
        if env_id is not None:
            ids[env_id] = name
    return ids


def _has_localized_id(entry: PathSetEntry, localization: str, model: type[KinematicModel]) -> bool:
    """Whether ``model`` on the set of ``entry`` has an id with ``localization``: the set
    takes it, and the model has the wheel encoders it counts, if it counts any."""
    if entry.env_localizations is not None and localization not in entry.env_localizations:
        return False
    needs_encoders = getattr(LOCALIZATIONS[localization], "needs_encoders", False)
    return has_encoders(model) or not needs_encoders


def env_specs() -> dict[str, dict[str, Any]]:
    """Every id the catalogues give, with the keyword arguments it makes the env with.

    :raises ValueError: for a path set whose ``env_models`` or ``env_localizations`` name
        an unknown model or localization
    """
    specs: dict[str, dict[str, Any]] = {}
    localizations = localization_ids()
    for set_name, entry in PATH_SETS.items():
        if entry.env_id is None:
            continue
        for model_name in MODELS if entry.env_models is None else entry.env_models:
            if model_name not in MODELS:
                raise ValueError(
                    f"path set {set_name!r}: env_models names an unknown model "
                    f"{model_name!r}; known: {sorted(MODELS)}"
                )
            model = MODELS[model_name]
            kwargs = {"model": model_name, "paths": set_name, **entry.env_kwargs}
            specs[f"mobile_envs/{model.env_id}-{entry.env_id}-v0"] = kwargs
            for suffix, localization in localizations.items():
                if _has_localized_id(entry, localization, model):
                    specs[f"mobile_envs/{model.env_id}-{entry.env_id}-{suffix}-v0"] = {
                        **kwargs,
                        "localization": localization,
                    }
            # The plant's presets, where the set has localized ids (not on training sets).
            if entry.env_localizations != ():
                for suffix, preset in PRESET_IDS.items():
                    specs[f"mobile_envs/{model.env_id}-{entry.env_id}-{suffix}-v0"] = {
                        **kwargs,
                        "plant": preset,
                    }
        unknown = set(entry.env_localizations or ()) - set(LOCALIZATIONS)
        if unknown:
            raise ValueError(
                f"path set {set_name!r}: env_localizations names unknown localizations "
                f"{sorted(unknown)}; known: {list(LOCALIZATIONS.names())}"
            )
    specs[GENERIC_ID] = {}
    return specs


def register_envs() -> tuple[str, ...]:
    """Register with Gymnasium every id of :func:`env_specs` it does not know yet (ids
    already registered stay as they are), so models, path sets and localizations registered
    after ``import mobile_envs`` get their ids; calling it again registers nothing.

    :return: the ids it registered
    """
    added = []
    for env_id, kwargs in env_specs().items():
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point=ENTRY_POINT,
            vector_entry_point=VECTOR_ENTRY_POINT,
            kwargs=kwargs,
        )
        added.append(env_id)
    return tuple(added)
