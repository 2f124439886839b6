"""A trained policy's deterministic actor as an ONNX graph, for deployment without SB3.

The graph computes what ``model.predict(observation, deterministic=True)`` returns for a Box
action space, batched:

- PPO: the Gaussian's mean, clipped to the action bounds (or, for a policy built with
  ``squash_output``, its tanh mapped onto them), as SB3's ``predict`` does; for a
  :class:`~agents.training.speed_floor.SpeedFloorPolicy`, with its speed floor before that;
- SAC and TQC: tanh of the squashed Gaussian's mean, mapped onto the action bounds;
- TD3: the actor's output (it ends in tanh), mapped onto the action bounds.

For the environments' actions in [-1, 1] the mapping onto the bounds is the identity.
Input ``observation``: float32, (batch, observation size); output ``action``: float32,
(batch, action size); the batch axis is dynamic.

It uses torch's TorchScript-based exporter (``torch.onnx.export(..., dynamo=False)``): with
torch 2.13 the dynamo exporter needs the onnxscript package, the TorchScript one nothing more
than torch (its deprecation warning is silenced here). Checked against onnxruntime in
tests/test_export.py; inference times in benchmarks/bench_export.py.

Requires the ``train`` extra; running the graph needs the ``export`` extra (onnxruntime).
"""

from __future__ import annotations

import io
import os
import pathlib
import warnings
from typing import Any

import gymnasium as gym
import torch
from stable_baselines3.common.base_class import BaseAlgorithm

from agents.training.speed_floor import SpeedFloorPolicy

#: The graph's input and output names.
INPUT_NAME = "observation"
OUTPUT_NAME = "action"
DEFAULT_OPSET = 17


class DeterministicActor(torch.nn.Module):
    """The deterministic action of a policy as one torch module: observation -> action.

    :param model: a PPO, SAC, TD3 or TQC model with Box observation and action spaces
    :raises ValueError: for other spaces or another kind of policy
    """

    low: torch.Tensor
    high: torch.Tensor

    def __init__(self, model: BaseAlgorithm):
        super().__init__()
        if not isinstance(model.action_space, gym.spaces.Box):
            raise ValueError(f"only Box action spaces export, not {model.action_space}")
        if not isinstance(model.observation_space, gym.spaces.Box):
            raise ValueError(f"only Box observation spaces export, not {model.observation_space}")
        policy: Any = model.policy
        policy.set_training_mode(False)
        self.policy = policy
        self.kind = _policy_kind(policy)
        low = torch.as_tensor(model.action_space.low, dtype=torch.float32)
        high = torch.as_tensor(model.action_space.high, dtype=torch.float32)
        self.register_buffer("low", low)
        self.register_buffer("high", high)
        self.squash = self.kind != "actor_critic" or bool(policy.squash_output)

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        action = self._raw_action(observation)
        if self.squash:  # SB3's unscale_action: [-1, 1] onto [low, high]
            return self.low + 0.5 * (action + 1.0) * (self.high - self.low)
        return torch.clamp(action, self.low, self.high)  # SB3's predict clips

    def _raw_action(self, observation: torch.Tensor) -> torch.Tensor:
        policy = self.policy
        if self.kind == "actor_critic":
            features = policy.extract_features(observation, policy.pi_features_extractor)
            latent = policy.mlp_extractor.forward_actor(features)
            mean = policy.action_net(latent)
            raw = torch.tanh(mean) if policy.squash_output else mean
            if isinstance(policy, SpeedFloorPolicy):  # its _predict floors the speed here
                return policy.floor_speed(observation, raw)
            return raw
        if self.kind == "squashed_gaussian":
            mean, _, _ = policy.actor.get_action_dist_params(observation)
            return torch.tanh(mean)
        action: torch.Tensor = policy.actor(observation)
        return action


def _policy_kind(policy: Any) -> str:
    """``actor_critic`` (PPO), ``squashed_gaussian`` (SAC, TQC) or ``deterministic`` (TD3)."""
    from stable_baselines3.common.distributions import (
        DiagGaussianDistribution,
        StateDependentNoiseDistribution,
    )
    from stable_baselines3.common.policies import ActorCriticPolicy

    if isinstance(policy, ActorCriticPolicy):
        if not isinstance(
            policy.action_dist, (DiagGaussianDistribution, StateDependentNoiseDistribution)
        ):
            raise ValueError(f"cannot export {type(policy.action_dist).__name__} actions")
        return "actor_critic"
    actor = getattr(policy, "actor", None)
    if actor is not None and hasattr(actor, "get_action_dist_params"):
        return "squashed_gaussian"
    if actor is not None and hasattr(actor, "mu"):
        return "deterministic"
    raise ValueError(f"cannot export a {type(policy).__name__}: no deterministic actor")


def onnx_bytes(model: BaseAlgorithm, opset: int = DEFAULT_OPSET) -> bytes:
    """The ONNX graph of ``model``'s deterministic actor (:class:`DeterministicActor`)."""
    actor = DeterministicActor(model)
    shape = model.observation_space.shape
    assert shape is not None
    example = torch.zeros((1, *shape), dtype=torch.float32)
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning)
        warnings.filterwarnings("ignore", message=".*legacy TorchScript-based ONNX export.*")
        torch.onnx.export(
            actor,
            (example,),
            buffer,  # type: ignore[arg-type]  # the TorchScript exporter writes file objects
            input_names=[INPUT_NAME],
            output_names=[OUTPUT_NAME],
            dynamic_axes={INPUT_NAME: {0: "batch"}, OUTPUT_NAME: {0: "batch"}},
            opset_version=opset,
            dynamo=False,
        )
    return buffer.getvalue()


def supported_opsets() -> range:
    """The ONNX opsets torch's TorchScript exporter writes (9 to 20 with torch 2.13)."""
    from torch.onnx import _constants

    return range(_constants.ONNX_MIN_OPSET, _constants.ONNX_TORCHSCRIPT_EXPORTER_MAX_OPSET + 1)


def check_opset(opset: int) -> int:
    """``opset`` if torch exports it.

    :raises ValueError: naming the opsets it does export
    """
    opsets = supported_opsets()
    if isinstance(opset, bool) or not isinstance(opset, int) or opset not in opsets:
        raise ValueError(
            f"opset {opset!r}: torch {torch.__version__} exports opsets {opsets[0]} to {opsets[-1]}"
        )
    return opset


def check_output(
    output: str | os.PathLike[str], model_file: str | os.PathLike[str] | None, overwrite: bool
) -> pathlib.Path:
    """``output`` if the graph may be written there: nothing is there, or a regular file that
    is not the model being exported and that ``overwrite`` allows to replace.

    :param output: where the graph goes
    :param model_file: the model file it is exported from, never replaced; None when unknown
    :param overwrite: whether an existing regular file may be replaced
    :raises ValueError: naming ``output`` and what is in the way
    """
    path = pathlib.Path(output)
    if not os.path.lexists(path):
        return path
    if path.is_symlink():
        raise ValueError(f"{path} is a symbolic link: write the graph to a path of its own")
    if not path.is_file():
        raise ValueError(f"{path} is not a regular file: write the graph to a path of its own")
    if model_file is not None and os.path.lexists(model_file) and path.samefile(model_file):
        raise ValueError(f"{path} is the model being exported: write the graph elsewhere")
    if not overwrite:
        raise ValueError(f"{path} exists, and is replaced only when asked (--force)")
    return path


def export_onnx(
    model: BaseAlgorithm,
    output: str | os.PathLike[str],
    opset: int = DEFAULT_OPSET,
    *,
    overwrite: bool = False,
    model_file: str | os.PathLike[str] | None = None,
) -> pathlib.Path:
    """Write ``model``'s deterministic actor to ``output`` as ONNX, atomically.

    :param model: a loaded PPO, SAC, TD3 or TQC model (:func:`agents.harness.policies.load_policy`)
    :param output: the ``.onnx`` file to write; its folder is created if needed
    :param opset: the ONNX opset (:func:`supported_opsets`)
    :param overwrite: whether an existing regular file at ``output`` may be replaced
    :param model_file: the file ``model`` was loaded from, which is never replaced
    :raises ValueError: for a policy that has no deterministic Box actor, an opset torch does
        not export, or an ``output`` :func:`check_output` refuses
    :raises OSError: naming ``output`` when it cannot be written
    """
    from agents.training.files import write_atomically

    check_opset(opset)
    check_output(output, model_file, overwrite)
    graph = onnx_bytes(model, opset)
    return write_atomically(output, lambda file: file.write(graph), overwrite=overwrite)
