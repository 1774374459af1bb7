"""The arena and the navigation tracks as gymnasium environments (docs/envs.md).

Observation: the learner's beam readings, right to left (m, ``float32``, each from 0 to its
beam's range: the numbers its network would read; then each further ``[sensor] channels``'s);
action: a symmetric ``float32`` ``Box(-1, 1, (2,))``, the paper's two network outputs in [0, 1]
rescaled (§3): forces ``(action + 1) / 2``, steering = gain · (force 1 − force 0)
(:func:`forces`); reward: 1 per step lived, and a spin in place takes the life's steps back, so
that an episode's return is the paper's fitness (§5, §5.3). ``terminated``: a collision or a
spin; ``truncated``: the step cap. ``reset``'s info holds the situation's ``key`` and
``situation``; a life's last step's info adds its ``steps``, ``outcome`` (a name of
:data:`~enn_traffic.sim.world.OUTCOMES`), ``fitness``, the collisions it ``suffered`` and what
it ``hit`` (:data:`END_KEYS`), the same keys single and vectorised.

A situation is the GA's (:meth:`ArenaWorld.situations`): ``reset(options={"key": k,
"situation": e})`` starts situation ``e`` of traffic key ``k``; without them, a training key
and situation are drawn from the reset's seed. :class:`RangefinderVectorEnv` steps N worlds
in one compiled call (:mod:`enn_traffic.envs.batch`), autoresetting in the same step.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from enn_traffic.config import Scenario, load_scenario
from enn_traffic.envs.batch import Batch, Situations
from enn_traffic.sim.arena import HIT, SUFFERED, ArenaWorld
from enn_traffic.sim.readings import COS, SIN, reading_bounds
from enn_traffic.sim.world import CAPPED, OUTCOMES, RUNNING, SPUN

TRAINING_KEYS = 1_000_000  # reset draws its traffic key among the first training keys


def rangefinder_world(scenario: str | Path | Scenario) -> ArenaWorld:
    """The arena or navigation world of a scenario (file or loaded); a clear error for the
    others."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    scenario = scenario.single_track()
    if scenario.world_kind != "arena":
        raise ValueError(f"{scenario.name}: not an arena or navigation scenario (a "
                         f"{scenario.world_kind} world)")
    return ArenaWorld(scenario)


OBSERVATION_DTYPES = ("float32", "float64")


def spaces_of(world: ArenaWorld, observation_dtype: str = "float32"
              ) -> tuple[spaces.Box, spaces.Box]:
    """The observation (beam readings, each from 0 to its beam's range, ``float32`` or, to
    replay the GA's lives exactly, ``float64``) and action (``float32`` ``Box(-1, 1, (2,))``:
    :func:`forces`) spaces of a world."""
    if observation_dtype not in OBSERVATION_DTYPES:
        raise ValueError(f"observation_dtype {observation_dtype!r}: expected one of "
                         f"{', '.join(OBSERVATION_DTYPES)}")
    low, high = reading_bounds(world.geometry)
    observation = spaces.Box(low.astype(observation_dtype), high.astype(observation_dtype),
                             low.shape, observation_dtype)
    return observation, spaces.Box(-1.0, 1.0, (2,), np.float32)


def forces(action, shape: tuple[int, ...] = (2,)) -> np.ndarray:
    """The paper's two network outputs in [0, 1] (§3) of actions in [-1, 1] of ``shape``:
    ``(action + 1) / 2``, an action outside the box clipped to it. A network's outputs ``o``
    are the action ``2 o − 1``. An action of another shape, or holding NaN or inf (a diverged
    policy), is a ValueError: clipped, it would drive on as a plausible one."""
    action = np.asarray(action, dtype=np.float64)
    if action.shape != shape:
        raise ValueError(f"an action of shape {action.shape}; expected {shape}")
    if not np.isfinite(action).all():
        raise ValueError(f"an action holds NaN or inf: {action.tolist()}")
    return (np.clip(action, -1.0, 1.0) + 1.0) / 2.0


def steering_of(action, gain: float) -> float:
    """The steering angle an action asks for: gain · (force 1 − force 0) (:func:`forces`)."""
    force = forces(action)
    return gain * (force[1] - force[0])


def action_of(outputs) -> np.ndarray:
    """A network's two outputs in [0, 1] (..., 2) as an action in [-1, 1]: ``2 outputs − 1``
    (the inverse of :func:`forces`), to drive a saved controller through the
    environments."""
    return 2.0 * np.asarray(outputs, dtype=np.float64) - 1.0


def observation_of(readings: np.ndarray, space: spaces.Box) -> np.ndarray:
    """Beam readings as the observation ``space`` holds them (a copy of its dtype)."""
    return readings.astype(space.dtype)


def checked_actions(actions: dict, agents: list[str]) -> dict:
    """A PettingZoo step's actions: one for every live agent, none for another (an action
    for an agent whose life ended, or for no agent, is an error, not ignored)."""
    missing = [agent for agent in agents if agent not in actions]
    if missing:
        raise KeyError(f"no action for {', '.join(missing)}")
    extra = [agent for agent in actions if agent not in agents]
    if extra:
        raise KeyError(f"an action for {', '.join(map(str, extra))}, which is not a live "
                       f"agent (live: {', '.join(agents) or 'none'})")
    return actions


# The outcome names by code; RUNNING (-1) reads the last, "" (a life going on)
OUTCOME_NAMES = np.array([OUTCOMES[code] for code in range(len(OUTCOMES))] + [""], dtype=object)
END_KEYS = ("steps", "outcome", "fitness", "suffered", "hit")  # a life's last info


def checked_render_mode(render_mode: str | None, metadata: dict) -> str | None:
    """``render_mode`` if the environment renders that way (``metadata["render_modes"]``) or
    None; any other is an error, never silently ignored."""
    if render_mode is not None and render_mode not in metadata["render_modes"]:
        raise ValueError(f"render_mode={render_mode!r}: this environment renders "
                         f"{metadata['render_modes'] or 'nothing'} (or None)")
    return render_mode


def checked_options(options: dict | None, names: tuple[str, ...] = ("key", "situation"),
                    others: str = "error") -> dict:
    """``reset``'s ``options``, of ``names`` only: ``key`` (a traffic key) and ``situation``
    each a whole number or None; a value of another type is an error, and so is any other
    option (``others="warn"``: a warning, for PettingZoo, whose API test resets with an option
    of its own) rather than silently ignored."""
    options = dict(options or {})
    unknown = sorted(map(str, set(options) - set(names)))
    if unknown:
        message = f"reset options {unknown}: the options are {list(names)}"
        if others != "warn":
            raise ValueError(message)
        warnings.warn(f"{message}; the others are ignored", stacklevel=3)
    for name in set(options) & {"key", "situation"}:
        value = options[name]
        if value is not None and (isinstance(value, bool)
                                  or not isinstance(value, int | np.integer)):
            raise ValueError(f"reset option {name}={value!r}: a whole number (int) or None")
    return options


def outcome_info(outcome: int, steps: int, tally: np.ndarray) -> dict:
    """What a life's end tells (:data:`END_KEYS`): its steps, outcome, fitness, collisions
    suffered and hit."""
    return {"steps": int(steps), "outcome": OUTCOMES[int(outcome)],
            "fitness": 0.0 if outcome == SPUN else float(steps),
            "suffered": int(tally[SUFFERED]), "hit": int(tally[HIT])}


class RangefinderEnv(gym.Env):
    """One learner in an arena or navigation world (a scenario file or a loaded scenario)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, scenario: str | Path | Scenario, render_mode: str | None = None,
                 observation_dtype: str = "float32"):
        self.render_mode = checked_render_mode(render_mode, self.metadata)
        self.world = rangefinder_world(scenario)
        self.observation_space, self.action_space = spaces_of(self.world, observation_dtype)
        self.batch = Batch(self.world, 1)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = checked_options(options)
        key = options.get("key")
        key = int(self.np_random.integers(TRAINING_KEYS) if key is None else key)
        pool = Situations.of_keys(self.world, [key])
        situation = options.get("situation")
        situation = int(self.np_random.integers(len(pool.seed)) if situation is None
                        else situation)
        if not 0 <= situation < len(pool.seed):
            raise ValueError(f"situation {situation}: key {key} has {len(pool.seed)}")
        self.batch.begin(pool, situation)
        self.started = {"key": key, "situation": situation}
        observation = observation_of(self.batch.worlds.observation[0], self.observation_space)
        return observation, dict(self.started)

    def step(self, action):
        if self.batch.pool is None or self.batch.worlds.outcome[0] != RUNNING:
            raise ResetNeeded("the life has ended (or not begun): call reset()")
        self.batch.step(forces(action).reshape(1, 2), autoreset=False)
        w = self.batch.worlds
        outcome = int(w.outcome[0])
        info = ({} if outcome == RUNNING else
                outcome_info(outcome, w.life[0], w.tally[0]) | self.started)
        return (observation_of(w.observation[0], self.observation_space), float(w.reward[0]),
                outcome not in (RUNNING, CAPPED), outcome == CAPPED, info)

    def render(self):
        if self.render_mode == "rgb_array":
            w = self.batch.worlds
            return picture(self.world, w.corners[0], w.pose[0], w.observation[:1])
        return None


class RangefinderVectorEnv(VectorEnv):
    """``num_envs`` learners, each in its own arena or navigation world, stepped by one
    compiled call; a world whose life ended starts the next situation of its pool in the same
    step (``info["final_obs"]``, ``info["final_info"]``). ``situations``: how many training
    keys the pool draws at reset; ``reset(options={"keys": [...]})`` names them instead (world
    ``i`` then starts the ``i``-th situation: test keys for a score)."""

    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, scenario: str | Path | Scenario, num_envs: int = 1,
                 situations: int = 64, render_mode: str | None = None,
                 observation_dtype: str = "float32"):
        self.render_mode = checked_render_mode(render_mode, self.metadata)
        self.world = rangefinder_world(scenario)
        self.num_envs = num_envs
        self.situations = situations
        self.single_observation_space, self.single_action_space = spaces_of(
            self.world, observation_dtype)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.batch = Batch(self.world, num_envs)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        chosen = checked_options(options, ("keys",)).get("keys")
        if chosen is None:
            chosen = self.np_random.integers(TRAINING_KEYS, size=self.situations)
        if len(chosen) == 0:
            raise ValueError('reset(options={"keys": [...]}) names no traffic key')
        self.batch.begin(Situations.of_keys(self.world, chosen))
        per_key = len(self.batch.pool.seed) // len(chosen)
        self.pool_keys = np.repeat(np.asarray(chosen, dtype=np.int64), per_key)
        self.pool_situations = np.tile(np.arange(per_key), len(chosen))
        w, every = self.batch.worlds, np.ones(self.num_envs, dtype=bool)
        return observation_of(w.observation, self.single_observation_space), {
            "key": self.pool_keys[w.situation], "_key": every,
            "situation": self.pool_situations[w.situation], "_situation": every}

    def step(self, actions):
        w, space = self.batch.worlds, self.single_observation_space
        if self.batch.pool is None:
            raise ResetNeeded("call reset() before step()")
        situation = w.situation.copy()  # the lives going on, before any autoreset
        self.batch.step(forces(actions, (self.num_envs, 2)), autoreset=True)
        ended = w.outcome != RUNNING
        terminated = ended & (w.outcome != CAPPED)
        infos = {}
        if ended.any():
            final = {"steps": w.life.copy(), "outcome": OUTCOME_NAMES[w.outcome],
                     "fitness": np.where(w.outcome == SPUN, 0.0, w.life.astype(np.float64)),
                     "suffered": w.final_tally[:, SUFFERED].copy(),
                     "hit": w.final_tally[:, HIT].copy(),
                     "key": self.pool_keys[situation],
                     "situation": self.pool_situations[situation]}
            final |= {f"_{name}": ended for name in END_KEYS + ("key", "situation")}
            infos = {"final_obs": observation_of(w.final_observation, space),
                     "_final_obs": ended, "final_info": final, "_final_info": ended}
        return (observation_of(w.observation, space), w.reward.astype(np.float32), terminated,
                ended & ~terminated, infos)

    def render(self):
        """The first :data:`RENDERED_WORLDS` worlds (or all, when fewer) as one RGB image:
        a grid of tiles, world 0 top left, row by row (blank tiles fill the last row)."""
        if self.render_mode != "rgb_array":
            return None
        w = self.batch.worlds
        tiles = [picture(self.world, w.corners[i], w.pose[i], w.observation[i:i + 1])
                 for i in range(min(self.num_envs, RENDERED_WORLDS))]
        columns = math.ceil(math.sqrt(len(tiles)))
        tiles += [np.full_like(tiles[0], 255)] * (-len(tiles) % columns)
        rows = [np.concatenate(tiles[r:r + columns], axis=1)
                for r in range(0, len(tiles), columns)]
        return np.concatenate(rows, axis=0)


RENDERED_WORLDS = 16  # a vector environment's render(): its first worlds, as a grid


def picture(world: ArenaWorld, corners: np.ndarray, pose: np.ndarray,
            readings: np.ndarray, around: tuple[float, float, float] | None = None
            ) -> np.ndarray:
    """An RGB image (H, W, 3) of the world: walls, bodies and the beams of the learners to
    where they read. The learners (blue) are the first ``len(readings)`` vehicles, ``readings``
    (L, B) theirs. ``around`` (x, y, half-width) frames a square; by default, every wall."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure

    figure = Figure(figsize=(4, 4), dpi=80)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_axes((0, 0, 1, 1))
    walls = world.geometry.walls
    axes.add_collection(LineCollection(walls.reshape(-1, 2, 2), colors="black", linewidths=1))
    table = world.geometry.beams
    beams = np.arctan2(table[:, SIN], table[:, COS])
    for v, reading in enumerate(readings):
        angles = pose[v, 2] + beams
        ends = pose[v, :2] + reading[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
        axes.add_collection(LineCollection([(pose[v, :2], end) for end in ends],
                                           colors="orange", linewidths=0.5))
    for v, body in enumerate(corners):
        axes.fill(body[:, 0], body[:, 1], color="tab:blue" if v < len(readings) else "tab:red")
    if around is None:  # every wall, with a margin: a wall on the frame's edge was cut away
        low, high = walls.reshape(-1, 2).min(axis=0), walls.reshape(-1, 2).max(axis=0)
        margin = 0.02 * (high - low).max()
        axes.set_xlim(low[0] - margin, high[0] + margin)
        axes.set_ylim(low[1] - margin, high[1] + margin)
    else:
        x, y, half = around
        axes.set_xlim(x - half, x + half)
        axes.set_ylim(y - half, y + half)
    axes.set_aspect("equal")
    axes.axis("off")
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
