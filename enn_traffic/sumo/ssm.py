"""SUMO's SSM device on the learners (closed loop): the options it writes by, and the
conflicts it wrote (docs/sumo.md, "Safety figures"). The learners carry it by their vehicle
type's ``has.ssm.device`` parameter (:func:`~enn_traffic.sumo.learners.add_learner`)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass

import numpy as np

from enn_traffic.sumo.command import LEARNER, SSM_FILE

# SUMO's SSM device on the learner (closed loop): conflicts with the vehicles around it,
# where time-to-collision falls below 1.5 s, the deceleration to avoid a crash exceeds
# 3 m/s², or the post-encroachment time falls below 2 s (docs/sumo.md, "Safety figures").
SSM_THRESHOLDS = {"TTC": 1.5, "DRAC": 3.0, "PET": 2.0}
SSM_RANGE_M = 50.0


def ssm_options() -> tuple[str, ...]:
    """SUMO options by which every SSM device measures and writes to ``SSM_FILE`` in the
    start's folder (read it with ``Simulation.close(read=...)``). They equip no vehicle: the
    learners carry a device by their type's parameter, every vehicle by ``traffic.outputs =
    ["ssm"]``. Not ``--device.ssm.explicit``: SUMO reads that list once per process and keeps
    it for every later start (docs/sumo.md, "One SUMO start, one process")."""
    return ("--device.ssm.measures", " ".join(SSM_THRESHOLDS),
            "--device.ssm.thresholds", " ".join(f"{v:g}" for v in SSM_THRESHOLDS.values()),
            "--device.ssm.range", f"{SSM_RANGE_M:g}", "--device.ssm.trajectories", "false",
            "--device.ssm.file", SSM_FILE, *SSM_DEFAULTS)


# SSM's other options at SUMO's defaults, set so that SUMO does not print for every learner
# that it "does not supply vehicle parameter 'device.ssm....'" (between steps, on the
# terminal).
SSM_DEFAULTS = ("--device.ssm.extratime", "5", "--device.ssm.geo", "false",
                "--device.ssm.mdrac.prt", "1", "--device.ssm.write-positions", "false",
                "--device.ssm.write-lane-positions", "false",
                "--device.ssm.exclude-conflict-types", "")


@dataclass(frozen=True)
class Conflicts:
    """What the learner's SSM device wrote: conflicts (encounters in which some measure passed
    its threshold), the lowest TTC seen (inf: none), and the conflicts by measure."""

    count: int = 0
    min_ttc: float = math.inf
    ttc: int = 0
    drac: int = 0
    pet: int = 0


def _conflicts(output: bytes) -> list:
    """The learners' conflict elements of an SSM output (none for an empty one): with
    ``traffic.outputs = ["ssm"]`` every vehicle has a device, writing into the same file."""
    try:
        conflicts = ElementTree.fromstring(output).findall("conflict")
    except ElementTree.ParseError:
        return []
    return [c for c in conflicts if (c.get("ego") or LEARNER).startswith(LEARNER)]


def _measure(conflict, tag: str, attribute: str = "value") -> float | None:
    """An attribute of a conflict's measure (``minTTC``, ``maxDRAC``, ``PET``), or None when it
    has none or it is "NA"."""
    element = conflict.find(tag)
    try:
        return float(element.get(attribute)) if element is not None else None
    except (TypeError, ValueError):  # "NA"
        return None


def read_conflicts(output: bytes) -> Conflicts:
    """Read an SSM output (an empty one: no conflict)."""
    conflicts = _conflicts(output)
    ttc = [v for c in conflicts if (v := _measure(c, "minTTC")) is not None]
    drac = [v for c in conflicts if (v := _measure(c, "maxDRAC")) is not None]
    pet = [v for c in conflicts if (v := _measure(c, "PET")) is not None]
    return Conflicts(len(conflicts), min(ttc, default=math.inf),
                     sum(v < SSM_THRESHOLDS["TTC"] for v in ttc),
                     sum(v > SSM_THRESHOLDS["DRAC"] for v in drac),
                     sum(v < SSM_THRESHOLDS["PET"] for v in pet))


def ttc_conflict_times(output: bytes) -> np.ndarray:
    """The SUMO times of the conflicts in an SSM output whose lowest time-to-collision fell
    below its threshold."""
    return np.array([_measure(c, "minTTC", "time") for c in _conflicts(output)
                     if (ttc := _measure(c, "minTTC")) is not None
                     and ttc < SSM_THRESHOLDS["TTC"]], dtype=np.float64)
