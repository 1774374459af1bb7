"""The names a scenario may use for its traffic, and the registry that binds names to code.

The schema (:mod:`enn_traffic.scenario`), the arena (:mod:`enn_traffic.sim.arena`) and the
experiments read :data:`STRATEGIES`; the world kinds (:data:`enn_traffic.worlds.WORLDS`), the
environments (:mod:`enn_traffic.envs`) and the experiments (:mod:`enn_traffic.experiments`)
are :class:`Registry` tables. A name missing from a table is an error, never a silent fallback
(docs/design.md, "Architecture")."""

from __future__ import annotations

import importlib
from collections.abc import Iterator

# Who steers a vehicle in the compiled rules: nobody (it stands), a network (the learner's, an
# evolved driver's, or the random-network strategy's fixed random genes), a scripted strategy
# (paper §5.3, Figure 11), or an action given from outside the step (a gymnasium or PettingZoo
# environment's).
NONE, NETWORK, STRAIGHT, CIRCLING, WANDER, ACTION = range(6)

# The arena's traffic strategies (``[traffic] strategy``) and the driver kind of their vehicles;
# ``none`` is a scenario without traffic vehicles. A strategy's steering is a branch of
# enn_traffic.sim.strategies.scripted_steering.
STRATEGIES = {
    "none": NONE,
    "random_network": NETWORK,
    "straight": STRAIGHT,
    "circling": CIRCLING,
    "wander": WANDER,
}
SUMO = "sumo"  # ``strategy = "sumo"``: the vehicles come from SUMO (docs/sumo.md)


class Registry:
    """Names bound to objects written ``"package.module:attribute"``, imported on first look-up
    (as gymnasium's entry points are), so that naming SUMO's world does not load SUMO for an
    arena run. An unknown name is a ``KeyError`` that lists the known ones; there is no
    ``get`` with a default, and ``name in table`` imports nothing."""

    def __init__(self, what: str, entries: dict[str, str]):
        self.what = what
        self._entries = dict(entries)

    def __getitem__(self, name: str) -> object:
        if name not in self._entries:
            raise KeyError(f"unknown {self.what} {name!r}; known: {', '.join(self._entries)}")
        module, attribute = self._entries[name].split(":")
        return getattr(importlib.import_module(module), attribute)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def target(self, name: str) -> str:
        """Where ``name``'s object lives, ``"package.module:attribute"``, without importing."""
        return self._entries[name]
