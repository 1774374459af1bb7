"""One checkpointed GA run (``enn-traffic run``), its ``generations.csv``, saved controllers,
and driving them on held-out traffic (``enn-traffic evaluate`` and ``render``)."""
