"""The names a scenario may use for its traffic: the arena's strategies and the driver kinds of
the compiled rules. The schema (:mod:`enn_traffic.config`), the arena
(:mod:`enn_traffic.sim.arena`) and the experiments read :data:`STRATEGIES`."""

from __future__ import annotations

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
