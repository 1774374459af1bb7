"""Every vehicle learning at once (paper §5.5, Tables 3–4): in the arena
(:mod:`~enn_traffic.experiments.crowds.arena`), among SUMO's traffic
(:mod:`~enn_traffic.experiments.crowds.sumo`), and on a user's own SUMO scenario
(``enn-traffic crowd``, :mod:`~enn_traffic.experiments.crowds.user`)."""
