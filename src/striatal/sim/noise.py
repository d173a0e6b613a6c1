"""Standard normals for trials and for batches of trials, drawn compiled.

A chapter trial needs 6000 standard normals (eq 5), a batch of B trials B x 6000.
NumPy's ``Generator.standard_normal`` draws them at about 10 ns each on one core: as
long as the SIMD kernel takes to run the trials on two. :func:`standard_normals` draws
the same numbers (NumPy's ziggurat on the generator's own bits, as Numba compiles
it for a ``Generator``: the same numbers and the same state after) in about half the
time, with the GIL released; :func:`standard_normal_rows` draws the rows of many
trials, from many generators, in one such call, different generators on Numba's
threads, each row the same numbers as drawn alone.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from typing import Any

import numba
import numpy as np
from numba.core import cgutils, types
from numba.extending import intrinsic
from numba.np.random.distributions import random_standard_normal

__all__ = [
    "standard_normal_rows",
    "standard_normals",
]

#: Numba's model of a NumPy bit generator: its C state and its functions' addresses.
_BITS = types.NumPyRandomBitGeneratorType("bit_generator")
#: The addresses of a NumPy bit generator class's next_uint64, next_uint32 and
#: next_double (C functions of the class, the same for each of its generators).
_FUNCTIONS: dict[type, tuple[int, int, int]] = {}


def _bit_generator_typing(
    typingctx: Any, state: Any, next_uint64: Any, next_uint32: Any, next_double: Any
) -> tuple[Any, Callable[..., Any]] | None:
    """The typing and code of :data:`_bit_generator`."""
    if not all(
        isinstance(t, types.Integer) for t in (state, next_uint64, next_uint32, next_double)
    ):
        return None
    sig = _BITS(state, next_uint64, next_uint32, next_double)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        # the fields the draws read: the state and the three functions (the Python
        # object and the address of NumPy's bitgen_t are left null: nothing reads them)
        bits = cgutils.create_struct_proxy(_BITS)(context, builder)
        bits.parent = cgutils.get_null_value(bits.parent.type)
        bits.bit_generator = cgutils.get_null_value(bits.bit_generator.type)
        bits.state_address = args[0]
        bits.state = args[0]
        bits.fnptr_next_uint64 = args[1]
        bits.fnptr_next_uint32 = args[2]
        bits.fnptr_next_double = args[3]
        return bits._getvalue()

    return sig, codegen


#: In compiled code, ``_bit_generator(state, next_uint64, next_uint32, next_double)``:
#: Numba's bit generator of the C state at ``state`` with the C functions at the three
#: addresses, what Numba unboxes from a NumPy ``Generator``'s ctypes interface, built
#: from integers, so that one compiled call can draw from many generators.
#: (Numba's annotations give the intrinsic its typing function's parameters, the typing
#: context first; compiled code calls it without.)
_bit_generator: Callable[[int, int, int, int], Any] = intrinsic(  # type: ignore[assignment]
    _bit_generator_typing
)


@numba.njit(nogil=True, cache=True, inline="always")
def _fill_row(bits: Any, out: np.ndarray, start: int, size: int) -> None:
    """out[start:start + size] filled with standard normals from ``bits`` (NumPy's
    ziggurat as Numba compiles it: the numbers of ``Generator.standard_normal``)."""
    for i in range(start, start + size):
        out[i] = random_standard_normal(bits)


@numba.njit(nogil=True, cache=True)
def _fill_one(
    state: int, next_uint64: int, next_uint32: int, next_double: int, out: np.ndarray
) -> None:
    """All of ``out`` (1-D) from the generator whose state and functions are at these
    addresses."""
    bits = _bit_generator(state, next_uint64, next_uint32, next_double)
    _fill_row(bits, out, 0, out.shape[0])


@numba.njit(nogil=True, cache=True, inline="always")
def _fill_chain(
    c: int,
    bits: np.ndarray,
    chain: np.ndarray,
    start: np.ndarray,
    size: np.ndarray,
    out: np.ndarray,
) -> None:
    """The rows of chain c (``chain[c]:chain[c + 1]``) in order, from generator c
    (``bits[c]``: its state's and functions' addresses)."""
    gen = _bit_generator(bits[c, 0], bits[c, 1], bits[c, 2], bits[c, 3])
    for r in range(chain[c], chain[c + 1]):
        _fill_row(gen, out, start[r], size[r])


@numba.njit(nogil=True, cache=True)
def _fill_chains(
    bits: np.ndarray, chain: np.ndarray, start: np.ndarray, size: np.ndarray, out: np.ndarray
) -> None:
    """Rows ``out[start[r]:start[r] + size[r]]``, chain after chain (:func:`_fill_chain`)."""
    for c in range(bits.shape[0]):
        _fill_chain(c, bits, chain, start, size, out)


@numba.njit(nogil=True, cache=True, parallel=True)
def _fill_chains_parallel(
    bits: np.ndarray, chain: np.ndarray, start: np.ndarray, size: np.ndarray, out: np.ndarray
) -> None:
    """:func:`_fill_chains` with the chains on Numba's threads."""
    for c in numba.prange(bits.shape[0]):
        _fill_chain(c, bits, chain, start, size, out)


def _addresses(rng: np.random.Generator) -> tuple[int, int, int, int]:
    """The address of ``rng``'s C state and of its bit generator's next_uint64,
    next_uint32 and next_double (NumPy's ctypes interface)."""
    bit_generator = rng.bit_generator
    interface = bit_generator.ctypes
    kind = type(bit_generator)
    functions = _FUNCTIONS.get(kind)
    if functions is None:
        u64, u32, double = (
            ctypes.cast(f, ctypes.c_void_p).value or 0
            for f in (interface.next_uint64, interface.next_uint32, interface.next_double)
        )
        functions = u64, u32, double
        if kind.__module__.startswith("numpy.random"):  # the class's own C functions
            _FUNCTIONS[kind] = functions
    return (interface.state_address, *functions)


def standard_normal_rows(
    rngs: Sequence[np.random.Generator],
    out: np.ndarray,
    starts: Sequence[int],
    sizes: Sequence[int],
    threads: int = 1,
) -> None:
    """Fill row r, ``out[starts[r]:starts[r] + sizes[r]]`` of the flat array ``out``, with
    standard normals from ``rngs[r]``, in one compiled call with the GIL released: each
    generator's rows in their order, as :func:`standard_normals` one row after another
    would (the numbers, and each generator's state after). With ``threads`` > 1,
    different generators are drawn on Numba's threads (as many as the caller's
    :func:`numba.get_num_threads`). No other thread may draw from these generators
    meanwhile. ``out``: 1-D, C-contiguous float64; a row outside it is refused
    (ValueError) before anything is drawn."""
    if any(start < 0 or start + size > out.size for start, size in zip(starts, sizes, strict=True)):
        raise ValueError("standard_normal_rows: a row lies outside out")
    chains: dict[int, list[int]] = {}
    for r, rng in enumerate(rngs):
        chains.setdefault(id(rng), []).append(r)
    rows = [r for chain in chains.values() for r in chain]
    bits = np.array([_addresses(rngs[chain[0]]) for chain in chains.values()], dtype=np.uint64)
    bounds = np.zeros(len(chains) + 1, dtype=np.int64)
    np.cumsum([len(chain) for chain in chains.values()], out=bounds[1:])
    fill = _fill_chains_parallel if threads > 1 and len(chains) > 1 else _fill_chains
    fill(
        bits.reshape(len(chains), 4),
        bounds,
        np.array([starts[r] for r in rows], dtype=np.int64),
        np.array([sizes[r] for r in rows], dtype=np.int64),
        out,
    )


def standard_normals(rng: np.random.Generator, out: np.ndarray) -> None:
    """Fill ``out`` (C-contiguous, any shape) with standard normals from ``rng`` in its
    flat order: the numbers, and the generator's state after, of
    ``rng.standard_normal(out=out)`` (tests/test_noise.py), about twice as fast. Like
    NumPy's methods it releases the GIL; unlike them it does not take the generator's
    lock, so no other thread may draw from ``rng`` meanwhile (a run's generator is
    used by one thread at a time)."""
    _fill_one(*_addresses(rng), out.reshape(-1))
