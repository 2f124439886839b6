"""Tests of mobile_envs._kernels.pcg64 against numpy's own Generator: the same numbers, the same
state."""

import numpy as np
import pytest
from numba import njit

from mobile_envs._kernels import pcg64
from mobile_envs._kernels.pcg64 import (
    draw_double,
    draw_doubles,
    draw_integer,
    draw_seed,
    draw_uniform,
    seeded_stream,
    store,
    store_streams,
    stream_doubles,
    stream_integers,
    stream_of,
    streams_of,
)

DOUBLE, UNIFORM, INTEGER, SEED = range(4)


@njit(cache=True)
def _draw_sequence(stream, kinds, highs, out):
    for index in range(kinds.size):
        kind = kinds[index]
        if kind == DOUBLE:
            out[index] = draw_double(stream)
        elif kind == UNIFORM:
            out[index] = draw_uniform(stream, -2.5, float(highs[index]))
        elif kind == INTEGER:
            out[index] = draw_integer(stream, highs[index])
        else:
            out[index] = draw_seed(stream)


def numpy_sequence(rng, kinds, highs):
    """The same draws made by numpy's Generator methods, one call each."""
    out = []
    for kind, high in zip(kinds, highs, strict=True):
        if kind == DOUBLE:
            out.append(rng.random())
        elif kind == UNIFORM:
            out.append(rng.uniform(-2.5, float(high)))
        elif kind == INTEGER:
            out.append(rng.integers(int(high)))
        else:
            out.append(rng.integers(2**63))
    return np.array(out, dtype=np.float64)


def mixed_draws(count, seed, max_high):
    """Kinds interleaved at random, so 32-bit halves are buffered across other draws; the
    integer bounds cover 1 (no draw), small ranges (many rejections), 2**32 - 1 and 2**32."""
    rng = np.random.default_rng(seed)
    kinds = rng.integers(0, 4, count)
    highs = rng.integers(1, 10, count)
    large = rng.random(count) < 0.3
    highs[large] = rng.integers(1, max_high, large.sum())
    highs[::17] = 1
    highs[5::23] = min(2**32 - 1, max_high)
    highs[7::29] = min(2**32, max_high)
    return kinds, highs


@pytest.mark.parametrize("seed", [0, 1, 77])
def test_a_pcg64_stream_draws_numpys_numbers_and_leaves_its_state(seed):
    kinds, highs = mixed_draws(5000, seed, 2**62)
    reference = np.random.default_rng(seed)
    expected = numpy_sequence(reference, kinds, highs)
    rng = np.random.default_rng(seed)
    stream = stream_of(rng)
    assert isinstance(stream, np.ndarray)
    drawn = np.empty(len(kinds))
    _draw_sequence(stream, kinds, highs, drawn)
    store(rng, stream)
    assert np.array_equal(drawn, expected)
    assert rng.bit_generator.state == reference.bit_generator.state
    assert rng.random() == reference.random()


def test_a_pending_32_bit_half_carries_into_and_out_of_a_stream():
    reference, rng = np.random.default_rng(4), np.random.default_rng(4)
    reference.integers(5)
    rng.integers(5)  # leaves half a word buffered in the state
    assert rng.bit_generator.state["has_uint32"] == 1
    kinds, highs = np.array([INTEGER, DOUBLE, INTEGER]), np.array([7, 1, 3])
    expected = numpy_sequence(reference, kinds, highs)
    stream = stream_of(rng)
    drawn = np.empty(3)
    _draw_sequence(stream, kinds, highs, drawn)
    store(rng, stream)
    assert np.array_equal(drawn, expected)
    assert rng.bit_generator.state == reference.bit_generator.state


def test_other_bit_generators_are_drawn_through_the_generator_itself():
    # numba's own Generator draws: the same numbers for bounds up to 2**32 (numba 0.68's
    # 64-bit bounded integers differ from numpy's, so larger bounds are not asked of them).
    kinds, highs = mixed_draws(2000, 3, 2**32)
    for make in (np.random.Philox, np.random.PCG64DXSM, np.random.PCG64):
        reference, rng = np.random.Generator(make(5)), np.random.Generator(make(5))
        expected = numpy_sequence(reference, kinds, highs)
        drawn = np.empty(len(kinds))
        _draw_sequence(rng, kinds, highs, drawn)
        assert np.array_equal(drawn, expected)
        assert np.array_equal(
            rng.bit_generator.random_raw(8), reference.bit_generator.random_raw(8)
        )
    philox = np.random.Generator(np.random.Philox(1))
    assert stream_of(philox) is philox


def state_words(rng):
    """A stream's words, read through numpy's documented ``bit_generator.state`` dict."""
    state = rng.bit_generator.state
    lcg = state["state"]
    return [
        lcg["state"] >> 64,
        lcg["state"] & (2**64 - 1),
        lcg["inc"] >> 64,
        lcg["inc"] & (2**64 - 1),
        state["has_uint32"],
        state["uinteger"],
    ]


@pytest.mark.parametrize("in_place", [True, False])
def test_many_streams_are_read_and_written_back_as_numpys_state_says(in_place, monkeypatch):
    # In place, the words come straight from the generators' memory (where numpy's layout
    # is the expected one, as on this machine); else through the state dicts. Either way
    # they are the dicts' words, and written back they set the generators' states.
    if in_place:
        assert pcg64._reads_in_place()
    else:
        monkeypatch.setattr(pcg64, "_reads_in_place", lambda: False)
    rngs = [np.random.default_rng(seed) for seed in range(12)]
    for rng in rngs[::3]:
        rng.integers(2**32, dtype=np.uint32)  # half a word buffered
    streams = streams_of(rngs)
    assert streams is not None
    assert streams.tolist() == [state_words(rng) for rng in rngs]
    references = [np.random.default_rng(100 + seed) for seed in range(12)]
    for reference in references[1::2]:
        reference.integers(5)
    store_streams(rngs, np.array([state_words(reference) for reference in references], np.uint64))
    for rng, reference in zip(rngs, references, strict=True):
        assert rng.bit_generator.state == reference.bit_generator.state
        assert rng.integers(2**32, size=3).tolist() == reference.integers(2**32, size=3).tolist()
    assert streams_of([rngs[0], np.random.Generator(np.random.Philox(1))]) is None


def test_draw_doubles_are_each_generators_own_random_calls():
    def generators():
        made = [np.random.default_rng(seed) for seed in range(5)]
        made[2].integers(5)  # half a word buffered, which random() does not use
        return [*made, np.random.Generator(np.random.Philox(9))]

    for rngs in (generators()[:5], generators()):  # all PCG64s (compiled), then a Philox
        references = generators()[: len(rngs)]
        drawn = draw_doubles(rngs, 3)
        assert drawn.shape == (len(rngs), 3)
        for row, (rng, reference) in enumerate(zip(rngs, references, strict=True)):
            assert drawn[row].tolist() == reference.random(3).tolist()
            assert (
                rng.integers(2**32, size=2).tolist() == reference.integers(2**32, size=2).tolist()
            )


@pytest.mark.parametrize("seed", [0, 1, 5, 2**32 - 1, 2**32, 2**40 + 7, 123456789, 2**63 - 1])
def test_seeded_stream_is_default_rngs_state(seed):
    stream = seeded_stream(seed)
    assert np.array_equal(stream, stream_of(np.random.default_rng(seed)))
    rng = np.random.default_rng(0)
    store(rng, stream)
    assert rng.random() == np.random.default_rng(seed).random()


@pytest.mark.parametrize("high", [1, 2, 3, 7, 2**31 + 5, 2**32, 2**40 + 3])
def test_stream_integers_and_doubles_are_each_generators_own_calls(high):
    def generators():
        made = [np.random.default_rng(seed) for seed in range(6)]
        made[3].integers(5)  # half a word buffered, which integers below 2**32 use
        return made

    rngs, references = generators(), generators()
    streams = streams_of(rngs)
    integers = stream_integers(streams, high)
    doubles = stream_doubles(streams, 2)
    for row, reference in enumerate(references):
        assert integers[row] == reference.integers(high)
        assert doubles[row].tolist() == reference.random(2).tolist()
    store_streams(rngs, streams)
    assert [rng.bit_generator.state for rng in rngs] == [
        reference.bit_generator.state for reference in references
    ]


def test_storing_streams_refuses_what_would_write_the_wrong_memory():
    rngs = [np.random.default_rng(0), np.random.default_rng(1)]
    streams = streams_of(rngs)
    philox = np.random.Generator(np.random.Philox(3))
    with pytest.raises(ValueError, match="PCG64"):
        store_streams([rngs[0], philox], streams)
    assert philox.random() == np.random.Generator(np.random.Philox(3)).random()
    with pytest.raises(ValueError, match=r"\(2, 6\) uint64"):
        store_streams(rngs, streams[:1])
    with pytest.raises(ValueError, match=r"\(2, 6\) uint64"):
        store_streams(rngs, streams.astype(np.int64))
