"""enn-traffic: evolve neural-network driving controllers in SUMO traffic (Eraqi et al., 2016)."""

__version__ = "0.1.0"
