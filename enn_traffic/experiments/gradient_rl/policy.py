"""PPO's and SAC's trained actor as plain numpy: scored without torch, saved as arrays."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from enn_traffic.core.io import write_atomic


@dataclass(eq=False)  # arrays: compare with numpy
class NumpyPolicy:
    """A policy's deterministic action (its mean, squashed for SAC) as plain numpy, with
    ``VecNormalize``'s observation scaling: scoring thousands of steps without torch's
    per-call cost, and a controller saved as arrays (:meth:`save`, :meth:`load`).
    ``layers``: ("linear", weight (in, out), bias), ("clip", low, high), ("Tanh" or "ReLU",
    None, None), in order."""

    layers: list[tuple[str, Any, Any]]
    mean: np.ndarray
    scale: np.ndarray
    squash: bool
    clip_obs: float = 10.0

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        x = np.clip((observation - self.mean) / self.scale, -self.clip_obs, self.clip_obs)
        for kind, a, b in self.layers:
            x = (x @ a + b if kind == "linear" else np.clip(x, a, b) if kind == "clip"
                 else np.tanh(x) if kind == "Tanh" else np.maximum(x, 0.0))
        return np.tanh(x) if self.squash else np.clip(x, -1.0, 1.0)

    def save(self, path: Path) -> None:
        arrays = {"mean": self.mean, "scale": self.scale, "squash": self.squash,
                  "clip_obs": self.clip_obs,
                  "kinds": np.array([kind for kind, _, _ in self.layers])}
        for i, (_, a, b) in enumerate(self.layers):
            if a is not None:
                arrays[f"a{i}"], arrays[f"b{i}"] = a, b
        write_atomic(path, lambda handle: np.savez(handle, **arrays), binary=True)

    @classmethod
    def load(cls, path: Path) -> NumpyPolicy:
        with np.load(path) as data:
            layers = [(str(kind), *((data[f"a{i}"], data[f"b{i}"]) if f"a{i}" in data.files
                                    else (None, None)))
                      for i, kind in enumerate(data["kinds"])]
            layers = [(kind, float(a), float(b)) if kind == "clip" else (kind, a, b)
                      for kind, a, b in layers]
            return cls(layers, data["mean"], data["scale"], bool(data["squash"]),
                       float(data["clip_obs"]))


def numpy_actor(model, obs_rms, clip_obs: float = 10.0) -> NumpyPolicy:
    """The SB3 PPO or SAC ``model``'s actor with ``obs_rms`` as a :class:`NumpyPolicy`."""
    import torch.nn as nn

    if hasattr(model.policy, "actor"):  # SAC
        layers = [*model.policy.actor.latent_pi, model.policy.actor.mu]
        squash = True
    else:  # PPO
        layers = [*model.policy.mlp_extractor.policy_net, model.policy.action_net]
        squash = False
    steps = []
    for layer in _flat(layers):
        if isinstance(layer, nn.Linear):
            steps.append(("linear", layer.weight.detach().numpy().T.copy(),
                          layer.bias.detach().numpy().copy()))
        elif isinstance(layer, nn.Hardtanh):  # SAC's clipped mean under gSDE
            steps.append(("clip", float(layer.min_val), float(layer.max_val)))
        elif isinstance(layer, (nn.Tanh, nn.ReLU)):
            steps.append((type(layer).__name__, None, None))
        else:
            raise TypeError(f"numpy_actor: no numpy form for {type(layer).__name__}")
    return NumpyPolicy(steps, obs_rms.mean.copy(), np.sqrt(obs_rms.var + 1e-8), squash,
                       clip_obs)


def _flat(modules) -> list:
    """``modules`` with every ``nn.Sequential`` opened, in order."""
    import torch.nn as nn

    return [leaf for module in modules for leaf in
            (_flat(module) if isinstance(module, nn.Sequential) else [module])]
