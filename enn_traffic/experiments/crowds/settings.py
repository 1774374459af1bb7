"""How every vehicle learns at once (paper §5.5): one record for the arena's crowds, the SUMO
families' and a user's ``enn-traffic crowd``, named as a scenario's ``[crowd]`` names them."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from enn_traffic.config import CrowdConfig

_KEYS = CrowdConfig()  # the [crowd] keys' defaults: the SUMO families' settings


@dataclass(frozen=True)
class CrowdSettings:
    """The ``[crowd]`` keys (:class:`~enn_traffic.config.CrowdConfig`: how long the learners
    learn, the span each rate is measured over, each chromosome's life cap, the rows of the
    evolved population each learner copies and the elites, the situations measured and the
    validation situations), the start and stopping Table 4's ablation varies
    (:mod:`enn_traffic.experiments.ablation`: ``random`` populations instead of the evolved
    rows; the authors' finishing rule, ``finish_steps``, with ``life_cap_steps`` 0), and what
    ``--quick`` changes of them."""

    learning_s: float = _KEYS.learning_s
    window_s: float = _KEYS.window_s
    life_cap_steps: int = _KEYS.life_cap_steps
    population_size: int = _KEYS.population_size
    elite_count: int = _KEYS.elite_count
    situations: int = _KEYS.situations
    validation_situations: int = _KEYS.validation_situations
    start_population: str = "evolved"  # or "random": the GA's first generation, per learner
    finish_steps: int = 0
    quick: Mapping[str, object] = field(default_factory=dict)

    @classmethod
    def of(cls, crowd: CrowdConfig) -> CrowdSettings:
        """A scenario's ``[crowd]`` keys as settings."""
        return cls(**crowd.model_dump(exclude={"counting"}))

    @property
    def windows(self) -> int:
        """The spans the learning lasts."""
        return round(self.learning_s / self.window_s)
