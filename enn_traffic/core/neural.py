"""The controller network: its chromosome layout and its one compiled forward pass (paper §3,
Figure 1).

A chromosome is a flat vector of every weight, layer by layer. Within a layer, all weights
coming *out of* one source neuron are consecutive, and the bias node is the last source
("source" layout, the paper's Figure 1). The authors' MATLAB code groups weights by *target*
neuron instead ("target" layout, docs/design.md, "The authors' code" 4); it is offered as an option.
Every layer, the output layer included, applies the logistic sigmoid. The steering angle is
``gain · (left − right)`` of the two outputs.

Every world drives its networks through :func:`steering`; this module sits below both the
simulation (``sim/``) and the GA (``evolution/``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from typing import Literal

import numpy as np
from numba import njit

Layout = Literal["source", "target"]


@dataclass(frozen=True)
class NetworkSpec:
    """Layer sizes from inputs to outputs, e.g. ``(19, 3, 2)``, and the gene layout."""

    layer_sizes: tuple[int, ...]
    layout: Layout = "source"

    def __post_init__(self) -> None:
        if len(self.layer_sizes) < 2 or min(self.layer_sizes) < 1:
            raise ValueError(f"invalid layer sizes {self.layer_sizes}")
        if self.layout not in ("source", "target"):
            raise ValueError(f"unknown layout {self.layout!r}")

    @property
    def layer_shapes(self) -> list[tuple[int, int]]:
        """(sources including the bias, targets) of each weight layer."""
        return [(n_in + 1, n_out) for n_in, n_out in pairwise(self.layer_sizes)]

    @property
    def layer_array(self) -> np.ndarray:
        """The layer sizes as the compiled pass takes them (int64 array)."""
        return np.asarray(self.layer_sizes, dtype=np.int64)

    @property
    def chromosome_length(self) -> int:
        return sum(rows * cols for rows, cols in self.layer_shapes)

    def source_order(self) -> np.ndarray:
        """Index array ``i`` such that ``chromosome[..., i]`` is in the source layout."""
        if self.layout == "source":
            return np.arange(self.chromosome_length)
        order, offset = [], 0
        for rows, cols in self.layer_shapes:
            # gene (source r, target c) sits at offset + c*rows + r in the target layout
            block = np.arange(rows * cols).reshape(cols, rows).T.ravel()
            order.append(offset + block)
            offset += rows * cols
        return np.concatenate(order)

    def in_source_layout(self, population: np.ndarray) -> np.ndarray:
        """Chromosomes (P, G) of this layout as contiguous float rows in the source layout,
        the order the compiled simulators read; a clear error for the wrong length."""
        population = np.atleast_2d(np.asarray(population, dtype=np.float64))
        if population.shape[1] != self.chromosome_length:
            raise ValueError(f"chromosomes have {population.shape[1]} genes; the network "
                             f"{self.layer_sizes} needs {self.chromosome_length}")
        return np.ascontiguousarray(population[:, self.source_order()])

    def from_source_layout(self, population: np.ndarray) -> np.ndarray:
        """Chromosomes (P, G) in the source layout back in this layout: the inverse of
        :meth:`in_source_layout`."""
        population = np.atleast_2d(np.asarray(population, dtype=np.float64))
        return np.ascontiguousarray(population[:, np.argsort(self.source_order())])

    def holds(self, smaller: NetworkSpec) -> bool:
        """Can :meth:`embed` put ``smaller``'s chromosomes in this network (as many layers,
        the same inputs and outputs, no hidden layer smaller)?"""
        sizes, small = self.layer_sizes, smaller.layer_sizes
        return len(sizes) == len(small) and sizes[::len(sizes) - 1] == small[::len(small) - 1] \
            and all(s <= b for s, b in zip(small, sizes, strict=True))

    def embed(self, population: np.ndarray, smaller: NetworkSpec) -> np.ndarray:
        """Chromosomes (P, g) of the ``smaller`` network (its layout) as chromosomes of this
        one in the source layout, computing the same outputs: each extra hidden neuron gets
        zero weights in and out. Needs as many layers, none smaller."""
        if not self.holds(smaller):
            raise ValueError(f"a network {smaller.layer_sizes} does not fit in "
                             f"{self.layer_sizes}")
        blocks = []
        for big, weights in zip(self.layer_shapes, smaller.weights(population), strict=True):
            padded = np.zeros((len(weights), *big))
            rows, cols = weights.shape[1:]
            padded[:, : rows - 1, :cols] = weights[:, :-1]  # the neurons' weights
            padded[:, -1, :cols] = weights[:, -1]  # the bias, the last source
            blocks.append(padded.reshape(len(weights), -1))
        return np.ascontiguousarray(np.concatenate(blocks, axis=1))

    def weights(self, population: np.ndarray) -> list[np.ndarray]:
        """Per-layer weight arrays of shape (P, sources + 1, targets)."""
        population = self.in_source_layout(population)
        matrices, offset = [], 0
        for rows, cols in self.layer_shapes:
            block = population[:, offset : offset + rows * cols]
            matrices.append(block.reshape(-1, rows, cols))
            offset += rows * cols
        return matrices

    def forward(self, population: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """Outputs (P, n_out) of P networks, each on its own input row (P, n_in), by the
        compiled pass the worlds drive with."""
        genes = self.in_source_layout(population)
        inputs = np.atleast_2d(np.asarray(inputs, dtype=np.float64))
        layer_sizes = self.layer_array
        activation, scratch = network_buffers(layer_sizes)
        outputs = np.empty((len(genes), self.layer_sizes[-1]))
        for p, row in enumerate(genes):
            network_outputs(row, layer_sizes, inputs[p], activation, scratch)
            outputs[p] = activation[: self.layer_sizes[-1]]
        return outputs


@njit(cache=True)
def network_buffers(layer_sizes):
    """The two work arrays :func:`network_outputs` needs, as wide as the widest layer."""
    width = max(layer_sizes.max(), 2)
    return np.empty(width), np.empty(width)


@njit(cache=True, inline="always")
def network_outputs(genes, layer_sizes, inputs, activation, scratch) -> None:
    """Forward pass of one source-layout chromosome on ``inputs``; the outputs are left in the
    first ``layer_sizes[-1]`` entries of ``activation`` (sigmoid at every layer).

    Each target's sum is kept in a register, bias first and then the sources in order (the
    same additions in the same order as a row-by-row pass); the gene index is unsigned, so
    no step pays for negative-index wraparound (docs/bench.md, "Instructions")."""
    for i in range(layer_sizes[0]):
        activation[i] = inputs[i]
    offset = np.uint64(0)
    for layer in range(layer_sizes.shape[0] - 1):
        n_in, n_out = np.uint64(layer_sizes[layer]), np.uint64(layer_sizes[layer + 1])
        bias = offset + n_in * n_out
        for j in range(n_out):
            target = np.uint64(j)
            total = genes[bias + target]
            gene = offset + target
            for i in range(n_in):
                total += activation[i] * genes[gene]
                gene += n_out
            scratch[j] = total
        for j in range(n_out):
            activation[j] = 1.0 / (1.0 + math.exp(-scratch[j]))
        offset = bias + n_out


@njit(cache=True, inline="always")
def steering(genes, layer_sizes, readings, activation, scratch, gain):
    """Steering angle = gain · (left − right) of the network's two outputs (paper §3)."""
    network_outputs(genes, layer_sizes, readings, activation, scratch)
    return gain * (activation[1] - activation[0])
