"""SUMO through libsumo (docs/sumo.md): the only package that imports libsumo.

SUMO runs a scenario's ``.sumocfg`` (as SUMO would: its begin time, route and additional
files) or its route files on the track's network with a fixed seed per traffic situation.
``warmup_s`` of SUMO time after the begin, the learner starts, and each step every SUMO
vehicle's position, angle, length and width become a body for the rangefinder and the
collision test (:mod:`enn_traffic.sim.sumo`).

- :mod:`~enn_traffic.sumo.command`: the command line, the folder each start writes into,
  the ids and files that are enn-traffic's own, the pose convention;
- :mod:`~enn_traffic.sumo.simulation`: one libsumo run (:class:`~enn_traffic.sumo.simulation.
  Simulation`), its vehicles in stable slots, its state saved;
- :mod:`~enn_traffic.sumo.states`: the warm-up, simulated once and saved as a state;
- :mod:`~enn_traffic.sumo.recording`: SUMO run once without the learner (replay mode);
- :mod:`~enn_traffic.sumo.learners`: learners put into SUMO and moved each step (closed loop);
- :mod:`~enn_traffic.sumo.ssm`: SUMO's SSM device on the learners, and its conflicts;
- :mod:`~enn_traffic.sumo.fresh`: each SUMO start in a process of its own.

SUMO reads the user's scenario and never writes into it (docs/sumo.md, "What is written
where"): each start writes into a folder of its own, what it prints on starting and ending
goes to a log there, and on closing the log and, when kept, the outputs move to the
scenario's ``sumo_folder``. This package's ``__init__`` imports nothing, so that
:mod:`~enn_traffic.sumo.fresh` loads without libsumo.
"""
