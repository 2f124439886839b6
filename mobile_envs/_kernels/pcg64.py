"""numpy's PCG64 generator and the draws the track generators make, in compiled code.

Random paths and mazes are drawn in numba kernels from each robot's own
``np.random.Generator``. Numba accepts a Generator as an argument, but unboxing one costs
about 15 us a call, more than drawing a whole path. So for the generators environments use
(``np.random.PCG64``, what ``np.random.default_rng`` builds) the kernels work on a *stream*:
the generator's state as six uint64 words, read before the call (:func:`stream_of`, or
:func:`streams_of` for many generators at once, straight from numpy's memory where its layout
is the expected one) and written back after it (:func:`store`, :func:`store_streams`).
:func:`stream_doubles` and :func:`stream_integers` draw ``random`` and ``integers`` from many
streams in one call, so a caller that draws several things from the same generators (a
restart: each robot's track, then its start pose) reads and writes their state once.
The compiled draws reproduce numpy's algorithms bit for bit: PCG64's 128-bit LCG with its
XSL-RR output, its buffered 32-bit draws, numpy's doubles, ``uniform`` and Lemire's bounded
integers, so a generator advanced through a stream ends in the state, and gives the numbers,
that numpy's own calls would. Any other bit
generator is handed to the kernels as the Generator itself; the draw functions accept either.

:func:`seeded_stream` builds, in compiled code, the stream of ``np.random.default_rng(seed)``
(numpy's ``SeedSequence`` hashing and PCG64 seeding), for the mazes' own carving generators.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar, cast

import numpy as np
from numba import carray, njit, types
from numba.extending import intrinsic, overload
from numpy.typing import NDArray

Stream = NDArray[np.uint64] | np.random.Generator
Drawn = TypeVar("Drawn")

# Word indices of a stream.
STATE_HIGH, STATE_LOW, INCREMENT_HIGH, INCREMENT_LOW, HAS_UINT32, UINTEGER = range(6)
STREAM_WORDS = 6

_WORD = (1 << 64) - 1
_ZERO, _ONE = np.uint64(0), np.uint64(1)
_LOW_32 = np.uint64(0xFFFFFFFF)
_SHIFT_32, _SHIFT_11, _SHIFT_58 = np.uint64(32), np.uint64(11), np.uint64(58)
_SIXTY_THREE = np.uint64(63)
_UINT64_MAX = np.uint64(0xFFFFFFFFFFFFFFFF)
# PCG_DEFAULT_MULTIPLIER_128, as its high and low words.
_MULTIPLIER_HIGH = np.uint64(0x2360ED051FC65DA4)
_MULTIPLIER_LOW = np.uint64(0x4385DF649FCCF645)
_DOUBLE_UNIT = 1.0 / 9007199254740992.0  # 2**-53
#: The largest seed ``integers(2**63)`` draws, for :func:`draw_seed`.
_SEED_RANGE = np.uint64(2**63 - 1)

# numpy's SeedSequence constants (numpy/random/bit_generator.pyx).
_POOL_SIZE = 4
_INIT_A, _MULT_A = np.uint64(0x43B0D7E5), np.uint64(0x931E8875)
_INIT_B, _MULT_B = np.uint64(0x8B51F9DD), np.uint64(0x58F38DED)
_MIX_MULT_L, _MIX_MULT_R = np.uint64(0xCA01F9DD), np.uint64(0x4973F715)
_XSHIFT = np.uint64(16)


def stream_of(rng: np.random.Generator) -> Stream:
    """What the compiled draws read ``rng`` through: the state words of a PCG64 generator,
    else the Generator itself. Hand the words back with :func:`store` after the draws."""
    if not _all_pcg64([rng]):
        return rng
    streams = streams_of([rng])
    assert streams is not None
    return streams[0]


def store(rng: np.random.Generator, stream: Stream) -> None:
    """Set ``rng`` to where the draws from ``stream`` (made by :func:`stream_of`) left it."""
    if isinstance(stream, np.random.Generator):
        return  # the kernels advanced the generator itself
    store_streams([rng], stream.reshape(1, STREAM_WORDS))


def streams_of(rngs: Sequence[np.random.Generator]) -> NDArray[np.uint64] | None:
    """The streams of many PCG64 generators, (k, STREAM_WORDS), in one call; None when any
    of them has another bit generator. Hand them back with :func:`store_streams`.

    Where numpy lays its PCG64 state out as this module expects (checked once, see
    :func:`_reads_in_place`), the words are read from the generators' memory in compiled
    code, through the address of the ``bitgen_t`` numpy hands C extensions in
    ``bit_generator.capsule``, for a fraction of a microsecond each; else through
    ``bit_generator.state``, a few microseconds each.
    """
    if not _all_pcg64(rngs):
        return None
    streams = np.empty((len(rngs), STREAM_WORDS), dtype=np.uint64)
    if _reads_in_place():
        _load_streams(_state_addresses(rngs), streams)
    else:
        for row, rng in enumerate(rngs):
            streams[row] = _words_of_state(rng.bit_generator.state)
    return streams


def store_streams(rngs: Sequence[np.random.Generator], streams: NDArray[np.uint64]) -> None:
    """Set each PCG64 generator ``rngs[k]`` to where the draws from ``streams[k]`` (made by
    :func:`streams_of`) left it.

    :raises ValueError: for a generator that is not a PCG64 or streams that are not a
        (len(rngs), STREAM_WORDS) uint64 array: the words would land in the wrong memory.
    """
    if not (
        isinstance(streams, np.ndarray)
        and streams.dtype == np.uint64
        and streams.shape == (len(rngs), STREAM_WORDS)
    ):
        raise ValueError(
            f"streams must be a ({len(rngs)}, {STREAM_WORDS}) uint64 array, a row per "
            f"generator; got {getattr(streams, 'dtype', type(streams).__name__)} of shape "
            f"{np.shape(streams)}"
        )
    if not _all_pcg64(rngs):
        raise ValueError("store_streams writes PCG64 states: every generator must be a PCG64")
    if _reads_in_place():
        _save_streams(_state_addresses(rngs), streams)
        return
    for rng, stream in zip(rngs, streams, strict=True):
        rng.bit_generator.state = _state_of_words(stream)


def through_streams(
    rngs: Sequence[np.random.Generator],
    from_streams: Callable[[NDArray[np.uint64]], Drawn],
    one_by_one: Callable[[], Drawn],
) -> Drawn:
    """``from_streams(streams)`` of the generators' streams (:func:`streams_of`), which
    advances them in place, then stored back into the generators; ``one_by_one()``, which
    draws from the generators themselves, when any of them is not a PCG64."""
    streams = streams_of(rngs)
    if streams is None:
        return one_by_one()
    drawn = from_streams(streams)
    store_streams(rngs, streams)
    return drawn


def draw_doubles(rngs: Sequence[np.random.Generator], count: int) -> NDArray[np.float64]:
    """(k, count): ``rngs[j].random(count)`` in row j, the same numbers, each generator left
    in the same state; drawn in one compiled call where every generator is a PCG64."""
    return through_streams(
        rngs,
        lambda streams: stream_doubles(streams, count),
        lambda: np.array([rng.random(count) for rng in rngs]).reshape(len(rngs), count),
    )


def _all_pcg64(rngs: Sequence[np.random.Generator]) -> bool:
    """Whether every generator's bit generator is a PCG64, whose state a stream holds."""
    return all(type(rng.bit_generator) is np.random.PCG64 for rng in rngs)


@njit(cache=True)
def stream_doubles(streams: NDArray[np.uint64], count: int) -> NDArray[np.float64]:
    """(k, count): ``rng.random(count)`` of each generator whose stream is a row of
    ``streams`` (k, STREAM_WORDS), drawn from the rows, which advance in place."""
    doubles = np.empty((streams.shape[0], count))
    for row in range(streams.shape[0]):
        for column in range(count):
            doubles[row, column] = _next_double(streams[row])
    return doubles


@njit(cache=True)
def stream_integers(streams: NDArray[np.uint64], high: int) -> NDArray[np.int64]:
    """(k,): ``rng.integers(high)`` (high >= 1) of each generator whose stream is a row of
    ``streams``, drawn from the rows, which advance in place."""
    integers = np.empty(streams.shape[0], dtype=np.int64)
    for row in range(streams.shape[0]):
        integers[row] = np.int64(_bounded(streams[row], np.uint64(high - 1)))
    return integers


# The bitgen_t a bit generator's capsule holds. Its ``ctypes`` interface would give the state
# address too, but each generator then keeps about 900 bytes of function objects.
_capsule_pointer = ctypes.pythonapi.PyCapsule_GetPointer
_capsule_pointer.restype = ctypes.c_void_p
_capsule_pointer.argtypes = [ctypes.py_object, ctypes.c_char_p]


def _state_addresses(rngs: Sequence[np.random.Generator]) -> NDArray[np.uint64]:
    """Where each PCG64 generator's ``bitgen_t`` lies (its first word points to numpy's
    ``pcg64_state`` struct), from the capsule numpy gives C extensions."""
    return np.array(
        [_capsule_pointer(rng.bit_generator.capsule, b"BitGenerator") for rng in rngs],
        dtype=np.uint64,
    )


def _words_of_state(state: Mapping[str, Any]) -> list[int]:
    """A stream's words from a PCG64 ``bit_generator.state`` dict."""
    lcg = state["state"]
    return [
        lcg["state"] >> 64,
        lcg["state"] & _WORD,
        lcg["inc"] >> 64,
        lcg["inc"] & _WORD,
        state["has_uint32"],
        state["uinteger"],
    ]


def _state_of_words(stream: NDArray[np.uint64]) -> dict[str, Any]:
    """The PCG64 ``bit_generator.state`` dict of a stream's words."""
    state_high, state_low, increment_high, increment_low, has_uint32, uinteger = stream.tolist()
    return {
        "bit_generator": "PCG64",
        "state": {
            "state": state_high << 64 | state_low,
            "inc": increment_high << 64 | increment_low,
        },
        "has_uint32": has_uint32,
        "uinteger": uinteger,
    }


@functools.cache
def _reads_in_place() -> bool:
    """Whether numpy's PCG64 state lies in memory as :func:`_load_streams` reads it: a
    ``bitgen_t`` whose first word points to a ``pcg64_state`` struct (a pointer to the LCG,
    then ``int has_uint32`` and ``uint32_t uinteger`` in one little-endian word) and the
    LCG's state and increment as 128-bit integers, low word first (numpy's layout where the
    compiler has 128-bit integers; not on MSVC). Checked by reading and writing a generator
    both ways."""
    rng = np.random.default_rng(20261201)
    rng.integers(2**32, dtype=np.uint32)  # a buffered half: has_uint32 and uinteger set
    expected = _words_of_state(rng.bit_generator.state)
    addresses = _state_addresses([rng])
    streams = np.zeros((1, STREAM_WORDS), dtype=np.uint64)
    _load_streams(addresses, streams)
    if streams[0].tolist() != expected or expected[HAS_UINT32] != 1:
        return False
    changed = np.array([[1, 2, 3, 5, 0, 7]], dtype=np.uint64)  # an odd increment, as PCG64's
    _save_streams(addresses, changed)
    return _words_of_state(rng.bit_generator.state) == changed[0].tolist()


def _pointer_to_words(typing_context, address):  # type: ignore[no-untyped-def]
    """The uint64 words at a memory address, as a pointer for ``numba.carray`` (a numba
    intrinsic: compiled code calls it as ``_words_at(address)``)."""
    pointer = types.CPointer(types.uint64)

    def codegen(context, builder, signature, arguments):  # type: ignore[no-untyped-def]
        return builder.inttoptr(arguments[0], context.get_value_type(pointer))

    return pointer(address), codegen


_words_at = cast(Callable[[Any], Any], intrinsic(_pointer_to_words))


# Words of numpy's bitgen_t and pcg64_state structs, and of the LCG (low word first).
_STATE_POINTER = 0
_LCG_POINTER, _BUFFERED_HALF = 0, 1
_LCG_STATE_LOW, _LCG_STATE_HIGH, _LCG_INCREMENT_LOW, _LCG_INCREMENT_HIGH = range(4)


@njit(cache=True)
def _state_words(address: np.uint64) -> tuple[NDArray[np.uint64], NDArray[np.uint64]]:
    """The words of the ``pcg64_state`` struct of the generator whose ``bitgen_t`` is at
    ``address`` (2), and of the LCG it points to (4), as arrays over that memory."""
    struct = carray(_words_at(carray(_words_at(address), 1)[_STATE_POINTER]), 2)
    return struct, carray(_words_at(struct[_LCG_POINTER]), 4)


@njit(cache=True)
def _load_streams(addresses: NDArray[np.uint64], streams: NDArray[np.uint64]) -> None:
    """Read the state of each generator, whose ``bitgen_t`` is at ``addresses[k]``, into
    ``streams[k]``."""
    for k in range(addresses.shape[0]):
        struct, lcg = _state_words(addresses[k])
        streams[k, STATE_HIGH] = lcg[_LCG_STATE_HIGH]
        streams[k, STATE_LOW] = lcg[_LCG_STATE_LOW]
        streams[k, INCREMENT_HIGH] = lcg[_LCG_INCREMENT_HIGH]
        streams[k, INCREMENT_LOW] = lcg[_LCG_INCREMENT_LOW]
        streams[k, HAS_UINT32] = struct[_BUFFERED_HALF] & _LOW_32
        streams[k, UINTEGER] = struct[_BUFFERED_HALF] >> _SHIFT_32


@njit(cache=True)
def _save_streams(addresses: NDArray[np.uint64], streams: NDArray[np.uint64]) -> None:
    """Write ``streams[k]`` into the state of the generator whose ``bitgen_t`` is at
    ``addresses[k]``."""
    for k in range(addresses.shape[0]):
        struct, lcg = _state_words(addresses[k])
        lcg[_LCG_STATE_HIGH] = streams[k, STATE_HIGH]
        lcg[_LCG_STATE_LOW] = streams[k, STATE_LOW]
        lcg[_LCG_INCREMENT_HIGH] = streams[k, INCREMENT_HIGH]
        lcg[_LCG_INCREMENT_LOW] = streams[k, INCREMENT_LOW]
        struct[_BUFFERED_HALF] = streams[k, HAS_UINT32] | (streams[k, UINTEGER] << _SHIFT_32)


# ---------------------------------------------------------------------------------------------
# PCG64 on state words. Every constant is a uint64: numba turns uint64 mixed with int64 into
# float64.


@njit(cache=True)
def _multiply_high(a: np.uint64, b: np.uint64) -> np.uint64:
    """The high word of the 128-bit product of two words."""
    a_low, a_high = a & _LOW_32, a >> _SHIFT_32
    b_low, b_high = b & _LOW_32, b >> _SHIFT_32
    low_low = a_low * b_low
    high_low = a_high * b_low
    low_high = a_low * b_high
    cross = (low_low >> _SHIFT_32) + (high_low & _LOW_32) + low_high
    return (high_low >> _SHIFT_32) + (cross >> _SHIFT_32) + a_high * b_high


@njit(cache=True)
def _next_uint64(stream: NDArray[np.uint64]) -> np.uint64:
    """PCG64's next output: advance the 128-bit LCG, then XSL-RR of the new state."""
    high, low = stream[STATE_HIGH], stream[STATE_LOW]
    product_low = low * _MULTIPLIER_LOW
    product_high = _multiply_high(low, _MULTIPLIER_LOW) + low * _MULTIPLIER_HIGH
    product_high += high * _MULTIPLIER_LOW
    new_low = product_low + stream[INCREMENT_LOW]
    carry = _ONE if new_low < product_low else _ZERO
    new_high = product_high + stream[INCREMENT_HIGH] + carry
    stream[STATE_HIGH], stream[STATE_LOW] = new_high, new_low
    mixed = new_high ^ new_low
    rotation = new_high >> _SHIFT_58
    return (mixed >> rotation) | (mixed << ((_ZERO - rotation) & _SIXTY_THREE))


@njit(cache=True)
def _next_uint32(stream: NDArray[np.uint64]) -> np.uint64:
    """Half an output: the low half now, the high half (kept in the state) next time."""
    if stream[HAS_UINT32] != _ZERO:
        stream[HAS_UINT32] = _ZERO
        return stream[UINTEGER]
    value = _next_uint64(stream)
    stream[HAS_UINT32] = _ONE
    stream[UINTEGER] = value >> _SHIFT_32
    return value & _LOW_32


@njit(cache=True)
def _next_double(stream: NDArray[np.uint64]) -> float:
    return float(_next_uint64(stream) >> _SHIFT_11) * _DOUBLE_UNIT


@njit(cache=True)
def _bounded(stream: NDArray[np.uint64], closed_range: np.uint64) -> np.uint64:
    """numpy's integer in [0, closed_range] (``random_bounded_uint64_fill`` for one value):
    nothing drawn for an empty range, Lemire's rejection on 32 or 64 bits."""
    if closed_range == _ZERO:
        return _ZERO
    if closed_range <= _LOW_32:
        if closed_range == _LOW_32:
            return _next_uint32(stream)
        exclusive = closed_range + _ONE
        scaled = _next_uint32(stream) * exclusive
        leftover = scaled & _LOW_32
        if leftover < exclusive:
            threshold = (_LOW_32 - closed_range) % exclusive
            while leftover < threshold:
                scaled = _next_uint32(stream) * exclusive
                leftover = scaled & _LOW_32
        return scaled >> _SHIFT_32
    if closed_range == _UINT64_MAX:
        return _next_uint64(stream)
    exclusive = closed_range + _ONE
    value = _next_uint64(stream)
    leftover = value * exclusive
    if leftover < exclusive:
        threshold = (_UINT64_MAX - closed_range) % exclusive
        while leftover < threshold:
            value = _next_uint64(stream)
            leftover = value * exclusive
    return _multiply_high(value, exclusive)


# ---------------------------------------------------------------------------------------------
# The draws, for a stream of words or a Generator. The Python bodies serve Generators outside
# compiled code; inside it the overloads below choose by the argument's type.


def draw_double(stream: Stream) -> float:
    """``rng.random()``: a double in [0, 1)."""
    assert isinstance(stream, np.random.Generator)
    return float(stream.random())


def draw_uniform(stream: Stream, low: float, high: float) -> float:
    """``rng.uniform(low, high)``: ``low + (high - low) * rng.random()``."""
    assert isinstance(stream, np.random.Generator)
    return float(stream.uniform(low, high))


def draw_integer(stream: Stream, high: int) -> int:
    """``rng.integers(high)``: an int in [0, high), high >= 1."""
    assert isinstance(stream, np.random.Generator)
    return int(stream.integers(high))


def draw_seed(stream: Stream) -> int:
    """``rng.integers(2**63)``: a seed in [0, 2**63)."""
    assert isinstance(stream, np.random.Generator)
    return int(stream.integers(2**63))


def _is_generator(stream: types.Type) -> bool:
    return isinstance(stream, types.NumPyRandomGeneratorType)


@overload(draw_double)
def _draw_double(stream):  # type: ignore[no-untyped-def]
    if _is_generator(stream):
        return lambda stream: stream.random()
    return lambda stream: _next_double(stream)


@overload(draw_uniform)
def _draw_uniform(stream, low, high):  # type: ignore[no-untyped-def]
    if _is_generator(stream):
        return lambda stream, low, high: stream.uniform(low, high)
    return lambda stream, low, high: low + (high - low) * _next_double(stream)


@overload(draw_integer)
def _draw_integer(stream, high):  # type: ignore[no-untyped-def]
    if _is_generator(stream):
        return lambda stream, high: stream.integers(0, high)
    return lambda stream, high: np.int64(_bounded(stream, np.uint64(high - 1)))


@overload(draw_seed)
def _draw_seed(stream):  # type: ignore[no-untyped-def]
    if _is_generator(stream):
        # numba's integers cannot take 2**63 as its high; the closed form draws the same.
        return lambda stream: stream.integers(0, 2**63 - 1, endpoint=True)
    return lambda stream: np.int64(_bounded(stream, _SEED_RANGE))


# ---------------------------------------------------------------------------------------------
# np.random.default_rng(seed): SeedSequence(seed) hashed into PCG64's seed words.


@njit(cache=True)
def _hashmix(value: np.uint64, hash_constant: NDArray[np.uint64]) -> np.uint64:
    """SeedSequence's ``hashmix`` on 32-bit values held in words."""
    value = (value ^ hash_constant[0]) & _LOW_32
    hash_constant[0] = (hash_constant[0] * _MULT_A) & _LOW_32
    value = (value * hash_constant[0]) & _LOW_32
    return value ^ (value >> _XSHIFT)


@njit(cache=True)
def _mix(x: np.uint64, y: np.uint64) -> np.uint64:
    result = (_MIX_MULT_L * x - _MIX_MULT_R * y) & _LOW_32
    return result ^ (result >> _XSHIFT)


@njit(cache=True)
def seeded_stream(seed: int) -> NDArray[np.uint64]:
    """The stream of ``np.random.default_rng(seed)``, for an int seed in [0, 2**63).

    numpy's ``SeedSequence``: the seed's 32-bit words mixed into a pool of four, the pool
    hashed into four 64-bit words, then PCG64's seeding (state words 0-1, increment words
    2-3: ``inc = seq << 1 | 1``; ``state = 0``; step; ``state += initstate``; step).
    """
    entropy = np.zeros(2, dtype=np.uint64)
    value, count = np.uint64(seed), 0
    while True:
        entropy[count] = value & _LOW_32
        count += 1
        value >>= _SHIFT_32
        if value == _ZERO:
            break
    hash_constant = np.array([_INIT_A], dtype=np.uint64)
    pool = np.zeros(_POOL_SIZE, dtype=np.uint64)
    for index in range(_POOL_SIZE):
        pool[index] = _hashmix(entropy[index] if index < count else _ZERO, hash_constant)
    for source in range(_POOL_SIZE):
        for target in range(_POOL_SIZE):
            if source != target:
                pool[target] = _mix(pool[target], _hashmix(pool[source], hash_constant))
    half_words = np.zeros(8, dtype=np.uint64)
    hashed = _INIT_B
    for index in range(8):
        data = pool[index % _POOL_SIZE] ^ hashed
        hashed = (hashed * _MULT_B) & _LOW_32
        data = (data * hashed) & _LOW_32
        half_words[index] = data ^ (data >> _XSHIFT)
    # Little-endian pairs of 32-bit values make the 64-bit seed words.
    seed_words = half_words[0::2] | (half_words[1::2] << _SHIFT_32)
    stream = np.zeros(STREAM_WORDS, dtype=np.uint64)
    stream[INCREMENT_HIGH] = (seed_words[2] << _ONE) | (seed_words[3] >> _SIXTY_THREE)
    stream[INCREMENT_LOW] = (seed_words[3] << _ONE) | _ONE
    _next_uint64(stream)
    low = stream[STATE_LOW] + seed_words[1]
    carry = _ONE if low < seed_words[1] else _ZERO
    stream[STATE_HIGH] = stream[STATE_HIGH] + seed_words[0] + carry
    stream[STATE_LOW] = low
    _next_uint64(stream)
    return stream
