"""Saved controllers (``best.npz``): a chromosome with the network and sensor it was made for,
and the spin rule it was evolved under."""

from __future__ import annotations

import functools
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import get_args

import numpy as np
from pydantic import ValidationError

from enn_traffic.config import RingConfig, Scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_input_file, inflation_problem, max_input_bytes, write_atomic
from enn_traffic.core.neural import Layout, NetworkSpec


@dataclass(frozen=True)
class Controller:
    chromosome: np.ndarray
    layer_sizes: tuple[int, ...]
    layout: str
    steering_gain_deg: float
    span_deg: float
    range: float
    fitness: float
    scenario_name: str
    generation: int
    # The spin rule of its training (paper §5.3); None in files written before it was kept.
    spin_window: int | None = None
    spin_variance: float | None = None
    # The sensor's further rings, each its RingConfig's fields in order ([sensor] rings).
    rings: tuple[tuple[float, float, float, float], ...] = ()
    # What each beam reads ([sensor] channels).
    channels: tuple[str, ...] = ("distance",)
    # The file it was loaded from (not saved): where an error in its values is reported.
    source: Path | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, chromosome: np.ndarray, fitness: float, generation: int
    ) -> Controller:
        return cls(
            chromosome=np.asarray(chromosome, dtype=np.float64),
            layer_sizes=tuple(scenario.layer_sizes),
            layout=scenario.network.layout,
            steering_gain_deg=scenario.network.steering_gain_deg,
            span_deg=scenario.sensor.span_deg,
            range=scenario.sensor.range,
            fitness=float(fitness),
            scenario_name=scenario.name,
            generation=int(generation),
            spin_window=scenario.episode.spin_window,
            spin_variance=scenario.episode.spin_variance,
            rings=tuple(tuple(ring.model_dump().values()) for ring in scenario.sensor.rings),
            channels=tuple(scenario.sensor.channels),
        )

    def save(self, path: str | Path) -> None:
        buffer = io.BytesIO()
        np.savez(
            buffer,
            chromosome=self.chromosome,
            layer_sizes=np.asarray(self.layer_sizes),
            layout=self.layout,
            steering_gain_deg=self.steering_gain_deg,
            span_deg=self.span_deg,
            range=self.range,
            fitness=self.fitness,
            scenario_name=self.scenario_name,
            generation=self.generation,
            **({} if self.spin_window is None else
               {"spin_window": self.spin_window, "spin_variance": self.spin_variance}),
            **({"rings": np.array(self.rings, dtype=np.float64)} if self.rings else {}),
            **({"channels": np.array(self.channels)} if self.channels != ("distance",) else {}),
        )
        write_atomic(path, lambda handle: handle.write(buffer.getvalue()), binary=True)

    @classmethod
    def load(cls, path: str | Path) -> Controller:
        path = Path(path)
        check_input_file(path, "controller file")
        _check_members(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                chromosome, layer_sizes = data["chromosome"], data["layer_sizes"]
                _real(chromosome, path, "chromosome")
                _real(layer_sizes, path, "layer_sizes")
                if layer_sizes.ndim != 1:
                    raise InputError(f"a list of sizes, not an array of shape "
                                     f"{layer_sizes.shape}", path, "layer_sizes")
                if not np.array_equal(layer_sizes, np.round(layer_sizes)):
                    raise InputError(f"layer sizes {layer_sizes.tolist()} are not whole numbers",
                                     path, "layer_sizes")
                layout = data["layout"]
                if layout.dtype.kind != "U" or str(layout) not in get_args(Layout):
                    raise InputError(f"layout {layout!r} is none of {get_args(Layout)}", path,
                                     "layout")
                number = functools.partial(_number, data, path)
                controller = cls(
                    chromosome=chromosome.astype(np.float64),
                    layer_sizes=tuple(int(n) for n in layer_sizes),
                    layout=str(layout),
                    steering_gain_deg=number("steering_gain_deg"),
                    span_deg=number("span_deg"),
                    range=number("range"),
                    fitness=number("fitness"),
                    scenario_name=str(data["scenario_name"]),
                    generation=int(number("generation", whole=True)),
                    **({"spin_window": int(number("spin_window", whole=True)),
                        "spin_variance": number("spin_variance")}
                       if "spin_window" in data.files else {}),
                    rings=(tuple(tuple(float(x) for x in ring) for ring in data["rings"])
                           if "rings" in data.files else ()),
                    **({"channels": tuple(str(name) for name in data["channels"])}
                       if "channels" in data.files else {}),
                    source=path,
                )
        except InputError:
            raise
        except Exception as exc:  # numpy raises many types on a damaged archive
            raise InputError(f"not a readable controller file ({type(exc).__name__}: {exc})",
                             path) from None
        try:
            spec = NetworkSpec(controller.layer_sizes, controller.layout)  # type: ignore[arg-type]
        except ValueError as exc:
            raise InputError(str(exc), path, "layer_sizes") from None
        if controller.chromosome.shape != (spec.chromosome_length,):
            raise InputError(
                f"chromosome has shape {controller.chromosome.shape}, the network "
                f"{controller.layer_sizes} needs {spec.chromosome_length} genes", path, "chromosome"
            )
        if not np.all(np.isfinite(controller.chromosome)):
            raise InputError("chromosome holds NaN or inf", path, "chromosome")
        for name in ("steering_gain_deg", "span_deg", "range", "spin_variance"):
            value = getattr(controller, name)
            if value is not None and not math.isfinite(value):
                raise InputError("holds NaN or inf", path, name)
        columns = len(RingConfig.model_fields)
        if any(len(ring) != columns for ring in controller.rings):
            raise InputError(f"each ring is a row of {columns} numbers "
                             f"({', '.join(RingConfig.model_fields)})", path, "rings")
        if not all(math.isfinite(x) for ring in controller.rings for x in ring):
            raise InputError("holds NaN or inf", path, "rings")
        for index, ring in enumerate(controller.rings):
            if ring[0] != int(ring[0]):
                raise InputError(f"ring {index}: beams {ring[0]:g} is not a whole number",
                                 path, "rings")
            try:
                RingConfig.model_validate(_ring_settings(ring))
            except ValidationError as exc:
                first = exc.errors()[0]
                raise InputError(f"ring {index}: {first['loc'][0]}: {first['msg']}", path,
                                 "rings") from None
        return controller

    def _named(self) -> str:
        """"the controller FILE's" (its file when it was loaded from one), for a misfit's
        message that names the scenario's file and key."""
        return f"the controller {self.source}'s" if self.source else "the controller's"

    def fit(self, scenario: Scenario, path: str | Path | None = None) -> Scenario:
        """``scenario`` with this controller's network and sensor, and the spin rule it was
        evolved under: a controller is measured by the rules it learnt by (the paper's rule,
        4.9 s within 8 m, calls a turn round in a narrow dead end a spin; docs/history.md,
        "Navigation"). A clear error if the scenario's rangefinder has another
        number of beams than the network has inputs."""
        if scenario.lane_keeping is not None:
            if self.layer_sizes[0] != scenario.inputs:
                raise InputError(
                    f"{self._named()} network takes {self.layer_sizes[0]} inputs, the "
                    f"scenario's camera gives {scenario.inputs}", path, "lane_keeping.lookahead_m")
        elif self.layer_sizes[0] != ((scenario.sensor.beams + sum(r[0] for r in self.rings))
                                     * len(self.channels)):
            raise InputError(
                f"{self._named()} network takes {self.layer_sizes[0]} beams, the scenario's "
                f"sensor has {scenario.sensor.beams}"
                + (f" (and the controller's own rings {sum(int(r[0]) for r in self.rings)})"
                   if self.rings else "")
                + (f", each read as {len(self.channels)} channels"
                   if len(self.channels) > 1 else ""), path, "sensor.beams")
        outputs = scenario.layer_sizes[-1]
        if self.layer_sizes[-1] != outputs:
            raise InputError(
                f"the controller's network gives {self.layer_sizes[-1]} outputs, the "
                f"scenario's needs {outputs} (steering and speed)", self.source, "layer_sizes")
        spin = ({} if self.spin_window is None else
                {"episode": {"spin_window": self.spin_window,
                             "spin_variance": self.spin_variance}})
        try:
            return scenario.with_overrides(
                network={
                    "hidden": list(self.layer_sizes[1:-1]),
                    "layout": self.layout,
                    "steering_gain_deg": self.steering_gain_deg,
                },
                sensor={"span_deg": self.span_deg, "range": self.range,
                        "rings": [_ring_settings(ring) for ring in self.rings],
                        "channels": list(self.channels)},
                **spin,
            )
        except InputError as exc:  # a value of the controller's, not of the scenario file
            key = re.sub(r"\[\d+\]$", "", exc.key or "")
            raise InputError(f"the controller's value is refused: {exc.message}", self.source,
                             CONTROLLER_FIELDS.get(key, exc.key)) from None


# The scenario key each controller field is checked as (Controller.fit), by the key's name.
CONTROLLER_FIELDS = {"network.hidden": "layer_sizes", "network.layout": "layout",
                     "network.steering_gain_deg": "steering_gain_deg",
                     "sensor.span_deg": "span_deg", "sensor.range": "range",
                     "episode.spin_window": "spin_window",
                     "episode.spin_variance": "spin_variance", "sensor.rings": "rings",
                     "sensor.channels": "channels"}


def _ring_settings(ring: tuple[float, ...]) -> dict:
    """A saved ring (its :class:`~enn_traffic.config.RingConfig` fields in order) as the
    scenario's ``[[sensor.rings]]`` settings."""
    return {**dict(zip(RingConfig.model_fields, ring, strict=True)), "beams": int(ring[0])}


def _number(data, path: Path, key: str, whole: bool = False) -> float:
    """The single number ``key`` of a controller file: a real number (an integer where
    ``whole``), never text, a boolean or an array."""
    value = data[key]
    if value.shape != () or value.dtype.kind not in "iuf":
        raise InputError(f"holds {value.dtype} of shape {value.shape}, not a number", path, key)
    if whole and value != np.round(value):
        raise InputError(f"{float(value):g} is not a whole number", path, key)
    return float(value)


def _check_members(path: Path) -> None:
    """Refuse a controller archive whose arrays would inflate as
    :func:`~enn_traffic.core.io.inflation_problem` refuses (a compressed bomb), before any is
    read."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
    except zipfile.BadZipFile:
        raise InputError("not a controller archive (.npz, as enn-traffic run writes)",
                         path) from None
    except Exception:  # a damaged archive raises many types: np.load reports it
        return
    limit = max_input_bytes()
    for member in members:
        problem = inflation_problem(member.file_size, member.compress_size, limit)
        if problem:
            raise InputError(f"{member.filename} {problem}: not a controller", path,
                             member.filename.removesuffix(".npy"))


def _real(array: np.ndarray, path: Path, key: str) -> None:
    """``array`` holds real numbers (integers or floats): never complex ones, whose imaginary
    parts a conversion would silently drop, nor text or booleans."""
    if array.dtype.kind not in "iuf":
        raise InputError(f"holds {array.dtype} values, not real numbers", path, key)
