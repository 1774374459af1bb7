import math

import numpy as np

from enn_traffic.core.neural import NetworkSpec


def sigmoid(z: float) -> float:
    return 1.0 / (1.0 + math.exp(-z))


def test_figure1_layout_groups_weights_by_source_neuron():
    """Paper Figure 1: a 2x3x2 network; genes of one source neuron are consecutive, bias last."""
    spec = NetworkSpec((2, 3, 2))
    assert spec.chromosome_length == 3 * 3 + 4 * 2
    names = [f"I{i}H{j}" for i in ("1", "2", "B1") for j in (1, 2, 3)]
    names += [f"H{i}O{j}" for i in ("1", "2", "3", "B2") for j in (1, 2)]
    chromosome = np.arange(spec.chromosome_length, dtype=float)
    hidden, output = spec.weights(chromosome)
    # hidden[source, target]: source 0 = I1, 1 = I2, 2 = bias B1
    assert hidden.shape == (1, 3, 3) and output.shape == (1, 4, 2)
    assert names[int(hidden[0, 0, 2])] == "I1H3"
    assert names[int(hidden[0, 1, 0])] == "I2H1"
    assert names[int(hidden[0, 2, 1])] == "IB1H2"
    assert names[int(output[0, 0, 1])] == "H1O2"
    assert names[int(output[0, 3, 0])] == "HB2O1"


def test_chromosome_lengths_of_the_authors_networks():
    # docs/design.md, "The authors' code" 4: 19, 10, 5, 3, 1 beams with 3 hidden neurons
    lengths = {n: NetworkSpec((n, 3, 2)).chromosome_length for n in (19, 10, 5, 3, 1)}
    assert lengths == {19: 68, 10: 41, 5: 26, 3: 20, 1: 14}
    assert NetworkSpec((19, 8, 4, 2)).chromosome_length == 20 * 8 + 9 * 4 + 5 * 2


def test_target_layout_is_the_authors_grouping():
    """Target layout: genes 1..20 feed hidden neuron 1 (inputs then bias), as in the MATLAB code."""
    spec = NetworkSpec((19, 3, 2), layout="target")
    chromosome = np.arange(68, dtype=float)
    hidden, output = spec.weights(chromosome)
    np.testing.assert_array_equal(hidden[0, :, 0], np.arange(20))
    np.testing.assert_array_equal(hidden[0, :, 2], np.arange(40, 60))
    np.testing.assert_array_equal(output[0, :, 1], np.arange(64, 68))


def test_a_chromosome_goes_back_from_the_source_layout():
    """The target layout's gene 1 (input 2 to hidden 1) is the source layout's gene 3 (one
    gene per hidden neuron before it), and back again."""
    spec = NetworkSpec((19, 3, 2), layout="target")
    chromosome = np.arange(68, dtype=float)
    source = spec.in_source_layout(chromosome)
    assert source[0, 3] == 1.0 and source[0, 1] == 20.0
    np.testing.assert_array_equal(spec.from_source_layout(source)[0], chromosome)


def test_compiled_forward_pass_matches_hand_computation():
    """The one forward pass every world drives with, against Figure 1's layout by hand."""
    spec = NetworkSpec((2, 3, 2))
    rng = np.random.default_rng(3)
    population = rng.uniform(-1, 1, size=(4, spec.chromosome_length))
    inputs = rng.uniform(0, 25, size=(4, 2))
    got = spec.forward(population, inputs)
    for p in range(4):
        g = population[p]
        hidden = [sigmoid(inputs[p, 0] * g[j] + inputs[p, 1] * g[3 + j] + g[6 + j])
                  for j in range(3)]
        out = [sigmoid(sum(hidden[i] * g[9 + 2 * i + k] for i in range(3)) + g[15 + k])
               for k in range(2)]
        np.testing.assert_allclose(got[p], out, rtol=1e-12)


def test_a_smaller_network_embedded_computes_the_same_outputs():
    rng = np.random.default_rng(5)
    for layout in ("source", "target"):
        small = NetworkSpec((19, 3, 2), layout)
        big = NetworkSpec((19, 6, 2), layout)
        genes = rng.uniform(-1, 1, (4, small.chromosome_length))
        inputs = rng.uniform(0, 25, (4, 19))
        embedded = big.embed(genes, small)  # source layout
        as_big = NetworkSpec((19, 6, 2)).forward(embedded, inputs)
        assert np.allclose(as_big, small.forward(genes, inputs))
        assert embedded.shape == (4, NetworkSpec((19, 6, 2)).chromosome_length)
    two = NetworkSpec((5, 2, 2, 2)), NetworkSpec((5, 4, 3, 2))
    genes = rng.uniform(-1, 1, (3, two[0].chromosome_length))
    inputs = rng.uniform(0, 1, (3, 5))
    assert np.allclose(two[1].forward(two[1].embed(genes, two[0]), inputs),
                       two[0].forward(genes, inputs))


def test_a_network_does_not_fit_in_a_smaller_one():
    import pytest

    with pytest.raises(ValueError, match="does not fit"):
        NetworkSpec((19, 2, 2)).embed(np.zeros((1, 68)), NetworkSpec((19, 3, 2)))
