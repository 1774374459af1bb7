"""What learns and how: ``[network]`` (the controller, paper §3), ``[ga]`` (paper §5),
``[episode]`` (a life's cap and the spin rule, §5.3) and ``[crowd]`` (every vehicle learning
at once, §5.5)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from enn_traffic.config.base import PositiveFloat, Section


class NetworkConfig(Section):
    """Fully connected sigmoid network; 2 outputs (right, left steering force)."""

    hidden: list[Annotated[int, Field(ge=1, le=1024)]] = Field(
        [3], max_length=16, description="hidden layer sizes (up to 16 layers of up to 1024; [] = "
        "inputs straight to outputs); inputs = beams × sensor channels, outputs = 2 (right, left "
        "force), sigmoid everywhere")
    steering_gain_deg: float = Field(
        90.0, gt=0, le=180, description="steering = gain × (left − right)")
    layout: Literal["source", "target"] = Field(
        "source", description="chromosome layout: `source` (paper Fig. 1: weights out of one "
        "neuron consecutive, bias last) or `target` (the authors' MATLAB grouping)")


class GAConfig(Section):
    """The paper's GA (§5) and its options; ``target_fitness`` stops a run early once a
    generation's best fitness reaches it."""

    population_size: int = Field(200, ge=2, le=100_000, description="chromosomes per generation")
    generations: int = Field(50, ge=1, le=100_000, description="generations to run")
    tournament_size: int = Field(
        10, ge=1, description="tournament selection, contestants drawn with replacement "
        "(left out: 10, or `population_size` when that is smaller)")
    crossover_probability: float = Field(
        1.0, ge=0, le=1, description="one-point crossover probability")
    crossover_cut_mean: float = Field(
        0.95, ge=0, le=1, description="the cut is at round(Normal(mean, std) × length)")
    crossover_cut_std: float = Field(
        0.05, ge=0, le=1, description="spread of the cut, as a share of the length")
    mutation_probability: float = Field(
        0.1, ge=0, le=1, description="per gene; a mutated gene is replaced by U[−init_range, "
        "init_range]")
    init_range: PositiveFloat = Field(
        1.0, le=1000, description="initial genes U[−init_range, init_range] (at most 1000)")
    elite_count: int = Field(
        0, ge=0, description="best chromosomes copied unchanged (0 = children replace parents, as "
        "in the paper)")
    target_fitness: float | None = Field(
        None, gt=0, description="stop early once a generation's best fitness "
        "reaches this")

    @model_validator(mode="before")
    @classmethod
    def _default_tournament(cls, data):
        """A tournament left out fits any population: 10, or the whole population."""
        if isinstance(data, dict) and "tournament_size" not in data:
            size = data.get("population_size", cls.model_fields["population_size"].default)
            if isinstance(size, int) and not isinstance(size, bool) and size >= 1:
                data = {**data, "tournament_size": min(size, 10)}
        return data

    @model_validator(mode="after")
    def _fits_population(self) -> GAConfig:
        if self.elite_count >= self.population_size:
            raise ValueError("elite_count: must be smaller than population_size")
        if self.tournament_size > self.population_size:
            raise ValueError("tournament_size: must not exceed population_size")
        return self


class EpisodeConfig(Section):
    """Episode rules: step cap and the spin ("rotating around itself") penalty of §5.3."""

    max_steps: int = Field(20_000, ge=1, le=10_000_000, description="step cap of one life")
    spin_window: int = Field(
        49, ge=2, le=100_000,
        description="a vehicle whose last `spin_window` positions have variance ≤ "
        "`spin_variance` m² on both axes is spinning in place: fitness 0 (paper §5.3)")
    spin_variance: float = Field(
        64.0, ge=0, description="see `spin_window` (m²)")


class CrowdConfig(Section):
    """Every vehicle driving by its own network at once (paper §5.5, Tables 3–4): how its
    collisions are counted."""

    counting: Literal["responsible", "lives_lost"] = Field(
        "responsible", description="the rates of Tables 3–4: `responsible` (responsible "
        "collisions per vehicle-second) or `lives_lost` (responsible collisions and spins, "
        "of all vehicles together per second: the paper's unit, all cars together; the "
        "authors' code ends a life at either, and their tables may count collisions alone, "
        "[results.md](results.md#all-vehicles-at-once-paper-55-tables-34)). "
        "Read by `reproduce`'s crowds (`table3`, `table4`, `sumo`, `city`) from the shipped "
        "arena and SUMO scenarios, and by `enn-traffic crowd`; `run` says it ignores it")
    learning_s: float = Field(
        1000.0, gt=0, le=100_000, description="`enn-traffic crowd`: SUMO seconds every vehicle "
        "learns together (Table 4), a multiple of `window_s`")
    window_s: float = Field(
        100.0, gt=0, le=10_000, description="`enn-traffic crowd`: the span each rate is "
        "measured over (Table 3 the first, Table 4 the one after learning) and the learning "
        "curve's step (SUMO seconds)")
    life_cap_steps: int = Field(
        150, ge=0, le=1_000_000, description="`enn-traffic crowd`: a life that reaches this "
        "many steps ends its chromosome's trial without a respawn (0: no cap)")
    population_size: int = Field(
        20, ge=2, le=100_000, description="`enn-traffic crowd`: rows of the evolved population "
        "(the individual run's last, its elites first) each vehicle copies and evolves; at "
        "most `ga.population_size`")
    elite_count: int = Field(
        4, ge=0, le=100_000, description="`enn-traffic crowd`: the best chromosomes of all "
        "vehicles, the elites of each vehicle's next generation")
    situations: int = Field(
        10, ge=1, le=10_000, description="`enn-traffic crowd`: traffic situations measured (the "
        "crowd test keys), each arm paired by situation")
    validation_situations: int = Field(
        2, ge=0, le=1_000, description="`enn-traffic crowd`: validation situations whose "
        "learners' counts are written (`table4_validation_learners.csv`: do they breed?)")

    @model_validator(mode="after")
    def _whole_windows(self) -> CrowdConfig:
        windows = self.learning_s / self.window_s
        if abs(windows - round(windows)) > 1e-9:
            raise ValueError(f"learning_s: {self.learning_s:g} must be a multiple of "
                             f"window_s ({self.window_s:g})")
        if self.elite_count >= self.population_size:
            raise ValueError(f"elite_count: {self.elite_count} must be less than "
                             f"population_size ({self.population_size})")
        return self
