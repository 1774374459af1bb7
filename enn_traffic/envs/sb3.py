"""Stable-Baselines3's vector API over the compiled vector environment (docs/envs.md, "Training
with Stable-Baselines3").

SB3 keeps a vector API of its own (``VecEnv``: a list of infos, ``terminal_observation``,
``dones``) rather than gymnasium's. :func:`sb3_vec_env` wraps a
:class:`~enn_traffic.envs.rangefinder.RangefinderVectorEnv` in it without copying worlds into
subprocesses: every world still steps in one compiled call. It needs the ``rl`` extra
(``pip install -e .[rl]``, docs/envs.md for a CPU-only torch)::

    from stable_baselines3 import PPO
    from enn_traffic.envs import make_vector_env
    from enn_traffic.envs.sb3 import sb3_vec_env

    venv = sb3_vec_env(make_vector_env("navigation_narrow", num_envs=32))
    PPO("MlpPolicy", venv).learn(100_000)
"""

from __future__ import annotations

import time

import numpy as np

from enn_traffic.envs.rangefinder import RangefinderVectorEnv

try:
    from stable_baselines3.common.vec_env import VecEnv
except ImportError:  # the optional rl extra
    raise ImportError("enn_traffic.envs.sb3 needs Stable-Baselines3: pip install -e .[rl] "
                      "(docs/envs.md: a CPU-only torch)") from None


class Sb3VecEnv(VecEnv):
    """``env``'s worlds under SB3's ``VecEnv`` API. A world whose life ended has already
    started its next situation (same-step autoreset, as SB3 expects); its last observation is
    ``infos[i]["terminal_observation"]`` and a life cut at ``max_steps`` says
    ``TimeLimit.truncated``, so that SB3 bootstraps its value. Each life's end also carries
    what SB3's ``Monitor`` would write (``episode``: return, length and time), so the adapter
    counts as wrapped in one: ``evaluate_policy`` reads true returns under ``VecNormalize``."""

    def __init__(self, env: RangefinderVectorEnv):
        self.env = env  # before VecEnv's own set-up, which reads its render_mode
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None
        self._began = time.time()

    def reset(self) -> np.ndarray:
        observation, _ = self.env.reset(seed=self._seeds[0] if self._seeds else None)
        self._reset_seeds()
        return observation

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        observation, reward, terminated, truncated, info = self.env.step(self._actions)
        done = terminated | truncated
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(done):
            final = info["final_info"]
            infos[i] = {"terminal_observation": info["final_obs"][i],
                        "TimeLimit.truncated": bool(truncated[i]),
                        "episode": {"r": float(final["fitness"][i]),
                                    "l": int(final["steps"][i]),
                                    "t": round(time.time() - self._began, 6)},
                        "outcome": str(final["outcome"][i])}
        return observation, reward, done, infos

    def close(self) -> None:
        self.env.close()

    def get_attr(self, name: str, indices=None) -> list:
        return [getattr(self.env, name)] * len(self._get_indices(indices))

    def set_attr(self, name: str, value, indices=None) -> None:
        setattr(self.env, name, value)

    def env_method(self, name: str, *args, indices=None, **kwargs) -> list:
        return [getattr(self.env, name)(*args, **kwargs)] * len(self._get_indices(indices))

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        from stable_baselines3.common.monitor import Monitor

        return [wrapper_class is Monitor] * len(self._get_indices(indices))


def sb3_vec_env(env: RangefinderVectorEnv) -> Sb3VecEnv:
    """``env`` (from :func:`enn_traffic.envs.make_vector_env`) as an SB3 ``VecEnv``."""
    return Sb3VecEnv(env)
