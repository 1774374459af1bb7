"""The compiled step (:mod:`~enn_traffic.sim.rules`, sensors, the bicycle model, the scripted
strategies) and the worlds that run it: the arena and navigation tracks, several tracks side
by side, crowds, SUMO's traffic (:mod:`enn_traffic.sim.sumo`) and highway-env's lane keeping
(:mod:`enn_traffic.sim.lane_keeping`); :mod:`~enn_traffic.sim.world` makes the one a scenario
describes, and :mod:`~enn_traffic.sim.reference` is the plain-Python oracle."""
