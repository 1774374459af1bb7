"""Scenario files (TOML): the schema, loading, and validation with clear errors
(docs/scenarios.md).

A scenario names a SUMO network, the vehicle, its rangefinder, the controller network, the GA
settings and the episode rules, one module per section (:mod:`~enn_traffic.config.track`,
:mod:`~enn_traffic.config.vehicle`, :mod:`~enn_traffic.config.sensor`,
:mod:`~enn_traffic.config.learning`, :mod:`~enn_traffic.config.traffic`,
:mod:`~enn_traffic.config.lane_keeping`), gathered by :class:`Scenario`
(:mod:`~enn_traffic.config.scenario`) and read by :func:`load_scenario`
(:mod:`~enn_traffic.config.load`); :mod:`~enn_traffic.config.sumo_inputs` says what it asks of
SUMO. Degrees appear only here (keys ending in ``_deg``); everything after loading is in
metres, seconds and radians. What every module of the package reads is imported here.
"""

from enn_traffic.config.base import (
    MAX_LEARNERS,
    MAX_SEED,
    XY,
    FilePath,
    Heading,
    Length,
    PositiveFloat,
    Radius,
    Range,
)
from enn_traffic.config.lane_keeping import LaneKeepingConfig, RoadDraw
from enn_traffic.config.learning import CrowdConfig, EpisodeConfig, GAConfig, NetworkConfig
from enn_traffic.config.load import (
    AUTO,
    MAX_KEY_PARTS,
    PACKAGE_PREFIX,
    load_scenario,
    network_named,
    package_file,
    sumo_sources,
)
from enn_traffic.config.scenario import MAX_POPULATION_GENES, QUOTED_DOT, Scenario
from enn_traffic.config.sensor import RingConfig, SensorConfig, fan
from enn_traffic.config.sumo_inputs import (
    begin_time,
    episode_steps,
    learner_start_time,
    read_files,
    route_files,
    scenario_digest,
    sumo_config,
)
from enn_traffic.config.track import TrackConfig
from enn_traffic.config.traffic import (
    ACTION,
    CIRCLING,
    NETWORK,
    NONE,
    STRAIGHT,
    STRATEGIES,
    SUMO,
    WANDER,
    CarFollowing,
    DriversConfig,
    Strategy,
    TrafficConfig,
)
from enn_traffic.config.vehicle import VehicleConfig

__all__ = [
    "ACTION",
    "AUTO",
    "CIRCLING",
    "CarFollowing",
    "CrowdConfig",
    "DriversConfig",
    "EpisodeConfig",
    "FilePath",
    "GAConfig",
    "Heading",
    "LaneKeepingConfig",
    "Length",
    "MAX_KEY_PARTS",
    "MAX_LEARNERS",
    "MAX_POPULATION_GENES",
    "MAX_SEED",
    "NETWORK",
    "NONE",
    "NetworkConfig",
    "PACKAGE_PREFIX",
    "PositiveFloat",
    "QUOTED_DOT",
    "Radius",
    "Range",
    "RingConfig",
    "RoadDraw",
    "STRAIGHT",
    "STRATEGIES",
    "SUMO",
    "Scenario",
    "SensorConfig",
    "Strategy",
    "TrackConfig",
    "TrafficConfig",
    "VehicleConfig",
    "WANDER",
    "XY",
    "begin_time",
    "episode_steps",
    "fan",
    "learner_start_time",
    "load_scenario",
    "network_named",
    "package_file",
    "read_files",
    "route_files",
    "scenario_digest",
    "sumo_config",
    "sumo_sources",
]
