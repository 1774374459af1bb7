"""Worlds among SUMO's traffic: replayed (:mod:`~enn_traffic.sim.sumo.replay`) or in closed
loop (:mod:`~enn_traffic.sim.sumo.world`), many learners in one SUMO
(:mod:`~enn_traffic.sim.sumo.crowd`), and which shared warm-ups a generation loads
(:mod:`~enn_traffic.sim.sumo.situations`). They drive SUMO through :mod:`enn_traffic.sumo`."""
