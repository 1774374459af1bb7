"""The project's worlds as gymnasium and PettingZoo environments (docs/envs.md).

``import enn_traffic.envs`` registers, under the ``enn_traffic/`` namespace, one id per
shipped scenario whose world an environment drives (:func:`register_envs`:
``enn_traffic/NavigationNarrow-v0``, ``enn_traffic/CityCologne3-v0``, ...;
:data:`REGISTERED` names their scenarios) and ``enn_traffic/Scenario-v0``, which takes
``scenario=PATH`` (a user's own SUMO scenario too, or a shipped scenario's name) and, for a
scenario of several tracks, ``track=i``. Gymnasium 1.x has no plugin entry points: without
the import, ``gymnasium.make("enn_traffic.envs:enn_traffic/NavigationNarrow-v0")`` imports
the module itself. Each id's ``max_episode_steps`` is its scenario's ``episode.max_steps``.
The arena and navigation ids vectorise in one compiled call::

    gymnasium.make_vec("enn_traffic/NavigationNarrow-v0", num_envs=4096,
                       vectorization_mode="vector_entry_point")

The vector environments made here (``vectorization_mode="vector_entry_point"``, and a SUMO
scenario's Sync/Async ones) reset a world whose life ended in the same step
(``AutoresetMode.SAME_STEP``); gymnasium's own ``"sync"`` mode keeps its next-step default.
``parallel_env(scenario, learners)`` gives the PettingZoo environment of several learners at
once, ``env(...)`` the same as an AEC environment.

The held-out tracks (``test_*``, ``unseen_*``) and lane keeping are not registered: the first
are for ``enn-traffic evaluate``, the second is highway-env's own environment.
"""

from __future__ import annotations

import numbers
import warnings
from pathlib import Path

import gymnasium as gym
from gymnasium.envs.registration import register, registry
from gymnasium.vector import AutoresetMode

from enn_traffic.config import Scenario, load_scenario
from enn_traffic.config.shipped import SCENARIOS, scenario_path
from enn_traffic.core.errors import InputError
from enn_traffic.core.registry import Registry

NAMESPACE = "enn_traffic"
def env_id(name: str) -> str:
    """The registered id of a shipped scenario: ``navigation_narrow`` →
    ``enn_traffic/NavigationNarrow-v0``."""
    return f"{NAMESPACE}/{''.join(part.title() for part in name.split('_'))}-v0"


def _scenario(scenario: str | Path | Scenario, track: int | None) -> Scenario:
    """The scenario (a file or loaded) on one track: ``track`` of a scenario of several."""
    loaded = (scenario if isinstance(scenario, Scenario)
              else load_scenario(scenario_path(scenario)))
    return loaded.single_track(track)


# Each world kind's environments, imported when first made (an arena environment does not
# load SUMO); a kind missing here has none (lane keeping: highway-env's own environment).
ENVS = Registry("world kind with a gymnasium environment", {
    "arena": "enn_traffic.envs.rangefinder:RangefinderEnv",
    "sumo": "enn_traffic.envs.sumo:SumoEnv",
})
VECTOR_ENVS = Registry("world kind with a vector environment", {
    "arena": "enn_traffic.envs.rangefinder:RangefinderVectorEnv",
    "sumo": "enn_traffic.envs:sumo_vector_env",
})
PARALLEL_ENVS = Registry("world kind with a PettingZoo environment", {
    "arena": "enn_traffic.envs.crowd:ArenaCrowdEnv",
    "sumo": "enn_traffic.envs.sumo:SumoCrowdEnv",
})


# The shipped tracks held out from training, validation (``unseen_*``) and test (``test_*``):
# no id, they are for ``enn-traffic evaluate``.
HELD_OUT = ("test_", "unseen_")


def _table_entry(table: Registry, scenario: Scenario):
    """The class ``table`` names for the scenario's world kind (a clear error if none)."""
    try:
        return table[scenario.world_kind]
    except KeyError as exc:
        raise ValueError(f"{scenario.name}: {exc.args[0]}") from None


def make_env(scenario: str | Path | Scenario | None = None, render_mode: str | None = None,
             track: int | None = None, observation_dtype: str = "float32") -> gym.Env:
    """The environment of an arena or navigation scenario
    (:class:`~enn_traffic.envs.rangefinder.RangefinderEnv`) or of a SUMO scenario
    (:class:`~enn_traffic.envs.sumo.SumoEnv`); ``track`` picks one of a scenario of several
    (``navigation_mixed``); ``observation_dtype="float64"``: the readings unrounded, to
    replay the GA's lives exactly (float32 readings part from them over long lives,
    docs/envs.md)."""
    if scenario is None:
        raise ValueError(f"{NAMESPACE}/Scenario-v0 needs scenario=PATH (a scenario file) or a "
                         "shipped scenario's name")
    scenario = _scenario(scenario, track)
    return _table_entry(ENVS, scenario)(scenario, render_mode=render_mode,
                                        observation_dtype=observation_dtype)


def make_vector_env(scenario: str | Path | Scenario, num_envs: int = 1, situations: int = 64,
                    render_mode: str | None = None, track: int | None = None,
                    max_episode_steps: int | None = None, observation_dtype: str = "float32"
                    ) -> gym.vector.VectorEnv:
    """``num_envs`` arena or navigation worlds stepped in one compiled call
    (:class:`~enn_traffic.envs.rangefinder.RangefinderVectorEnv`); for a SUMO scenario,
    gymnasium's ``SyncVectorEnv`` of replays or ``AsyncVectorEnv`` of closed loops (libsumo
    runs one SUMO per process). ``track`` as in :func:`make_env`; ``max_episode_steps`` (as
    ``gymnasium.make_vec`` passes it) is the worlds' step cap."""
    if not isinstance(num_envs, numbers.Integral) or num_envs < 1:
        raise ValueError(f"num_envs must be a whole number of at least 1, not {num_envs!r}")
    scenario = _scenario(scenario, track)
    if max_episode_steps is not None and max_episode_steps != scenario.episode.max_steps:
        scenario = scenario.with_overrides(episode={"max_steps": int(max_episode_steps)})
    return _table_entry(VECTOR_ENVS, scenario)(scenario, num_envs, situations, render_mode,
                                               observation_dtype)


def sumo_vector_env(scenario: Scenario, num_envs: int, situations: int,
                    render_mode: str | None, observation_dtype: str = "float32"
                    ) -> gym.vector.VectorEnv:
    """SUMO scenarios' vector environment: gymnasium's ``SyncVectorEnv`` of replays, or
    ``AsyncVectorEnv`` of closed loops (libsumo runs one SUMO per process); ``situations`` is
    the arena's pool and unused here."""
    vector = (gym.vector.AsyncVectorEnv if scenario.traffic.mode == "closed-loop"
              else gym.vector.SyncVectorEnv)
    return vector([lambda: make_env(scenario, render_mode, None, observation_dtype)] * num_envs,
                  autoreset_mode=AutoresetMode.SAME_STEP)


def parallel_env(scenario: str | Path | Scenario, learners: int | None = None,
                 render_mode: str | None = None, track: int | None = None,
                 observation_dtype: str = "float32"):
    """A PettingZoo ``ParallelEnv`` of several learners at once, one agent per learning
    vehicle: the arena crowd of paper §5.5
    (:class:`~enn_traffic.envs.crowd.ArenaCrowdEnv`), or for a SUMO scenario the learners
    among its live traffic (:class:`~enn_traffic.envs.sumo.SumoCrowdEnv`; no rendering).
    ``track`` as in :func:`make_env`."""
    scenario = _scenario(scenario, track)
    return _table_entry(PARALLEL_ENVS, scenario)(scenario, learners, render_mode,
                                                 observation_dtype)


def env(scenario: str | Path | Scenario, learners: int | None = None,
        render_mode: str | None = None, track: int | None = None,
        observation_dtype: str = "float32"):
    """:func:`parallel_env` as a PettingZoo AEC environment (agents act in turn)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(scenario, learners, render_mode, track,
                                        observation_dtype))


def register_envs() -> tuple[str, ...]:
    """Register ``enn_traffic/Scenario-v0`` and an id for each shipped scenario whose world
    kind has an environment (:data:`ENVS`: not lane keeping, not several tracks), the held-out
    tracks aside; the names of those scenarios, in order."""
    entry_points = {"entry_point": f"{__name__}:make_env",
                    "vector_entry_point": f"{__name__}:make_vector_env"}
    if f"{NAMESPACE}/Scenario-v0" not in registry:
        register(f"{NAMESPACE}/Scenario-v0", **entry_points)
    names = []
    for path in sorted(SCENARIOS.glob("*.toml")):
        if path.stem.startswith(HELD_OUT):
            continue
        try:
            scenario = load_scenario(path)
        except InputError as exc:  # a file a user broke there: the others keep their ids
            warnings.warn(f"no gymnasium id for {exc}", stacklevel=2)
            continue
        if scenario.world_kind not in ENVS:
            continue
        names.append(path.stem)
        if env_id(path.stem) not in registry:
            register(env_id(path.stem), **entry_points,
                     max_episode_steps=scenario.episode.max_steps,
                     kwargs={"scenario": str(path)})
    return tuple(names)


# The shipped scenarios with an id (``enn_traffic/NavigationNarrow-v0`` ...).
REGISTERED = register_envs()
