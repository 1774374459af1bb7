"""Simulation: the rules of a step (:mod:`~enn_traffic.sim.rules`) and the worlds that run
them — the arena (:mod:`~enn_traffic.sim.arena`), SUMO traffic replayed or live
(:mod:`~enn_traffic.sim.sumo.replay`, :mod:`~enn_traffic.sim.sumo.world`) and many drivers at once
(:mod:`~enn_traffic.sim.crowd`)."""
