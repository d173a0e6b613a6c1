"""Noise drawn compiled and on threads (striatal.sim.noise, bench.batch_normals): NumPy's
numbers, the same as drawn alone."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from striatal.sim import bench, noise


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("rows", [0, 1, 2, 5, 256])
def test_batch_normals_are_the_children_of_the_generator(threads: int, rows: int) -> None:
    """One contiguous part per Numba thread (fewer when the rows are few), each what its
    own rng.spawn child gives in NumPy (drawn on the threads at once): reproducible from
    the seed, standard normal, whatever the timing of the threads."""
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        threads = numba.get_num_threads()
        a = bench.batch_normals(np.random.default_rng(7), rows, 300)
        b = bench.batch_normals(np.random.default_rng(7), rows, 300)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert a.shape == (rows, 300)
    assert np.array_equal(a, b)
    parts = max(1, min(threads, rows))
    step = -(-rows // parts)
    children = np.random.default_rng(7).spawn(parts)
    want = [c.standard_normal((min(step, rows - i * step), 300)) for i, c in enumerate(children)]
    assert np.array_equal(a, np.concatenate(want))
    if rows == 256:
        assert abs(a.mean()) < 0.01 and abs(a.std() - 1.0) < 0.01


@pytest.mark.parametrize("shape", [(0,), (1,), (6000,), (3000, 2), (200_000,)])
def test_compiled_normals_are_numpy_s_numbers_and_leave_its_state(shape: tuple[int, ...]) -> None:
    """standard_normals fills what rng.standard_normal(out=) fills (its ziggurat's tail
    too: 200 000 draws reach |z| > 3.44 about 120 times), flat order for a 2-D block,
    and leaves the generator where NumPy's draw leaves it; for a PCG64 and an MT19937."""
    for bits in (np.random.PCG64, np.random.MT19937):
        for seed in range(3):
            mine, theirs = np.random.Generator(bits(seed)), np.random.Generator(bits(seed))
            got, want = np.empty(shape), np.empty(shape)
            noise.standard_normals(mine, got)
            theirs.standard_normal(out=want)
            assert np.array_equal(got, want)
            assert np.array_equal(
                mine.bit_generator.random_raw(8), theirs.bit_generator.random_raw(8)
            )
            assert mine.standard_normal() == theirs.standard_normal()
    tail = np.empty(200_000)
    noise.standard_normals(np.random.default_rng(1), tail)
    assert (np.abs(tail) > 3.4426).sum() > 50


def test_compiled_normals_take_rows_of_a_block_in_place() -> None:
    """A row of a (B, n) block is filled in place, the other rows untouched."""
    block = np.zeros((3, 500))
    noise.standard_normals(np.random.default_rng(4), block[1])
    assert np.array_equal(block[1], np.random.default_rng(4).standard_normal(500))
    assert not block[0].any() and not block[2].any()


@pytest.mark.parametrize("threads", [1, 2])
def test_rows_of_many_generators_are_each_generator_s_stream(threads: int) -> None:
    """standard_normal_rows fills each row from its generator, a generator's rows in
    their order wherever they lie in the buffer, as NumPy would draw them one after
    another: the numbers, and each generator's state after; for each of NumPy's bit
    generators, with rows long enough to reach the ziggurat's tail (|z| > 3.44, where
    it also draws doubles), empty rows, and on Numba's threads."""
    kinds = (np.random.PCG64, np.random.MT19937, np.random.Philox, np.random.SFC64)
    mine = [np.random.Generator(kind(seed)) for seed, kind in enumerate(kinds)]
    theirs = [np.random.Generator(kind(seed)) for seed, kind in enumerate(kinds)]
    # (generator, size) of each row in request order; the rows lie in the buffer in
    # another order than the requests', a generator's rows spread among the others'
    requests = [(0, 6000), (1, 100), (0, 0), (2, 50_000), (3, 7), (1, 6000), (0, 25)]
    requests += [(3, 60_000), (2, 1)]
    sizes = [size for _, size in requests]
    starts = np.cumsum([0, *sizes[::-1]])[:-1][::-1].tolist()  # the last row first
    out = np.full(sum(sizes), np.nan)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        noise.standard_normal_rows(
            [mine[g] for g, _ in requests], out, starts, sizes, threads=threads
        )
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for (g, size), start in zip(requests, starts, strict=True):
        want = theirs[g].standard_normal(size)
        assert np.array_equal(out[start : start + size], want)
    assert not np.isnan(out).any()
    assert (np.abs(out) > 3.4426).sum() > 20
    for a, b in zip(mine, theirs, strict=True):
        assert np.array_equal(a.bit_generator.random_raw(4), b.bit_generator.random_raw(4))
        assert a.standard_normal() == b.standard_normal()


def test_rows_need_not_fill_the_buffer_and_none_is_a_no_op() -> None:
    """Only the rows given are written; no rows draws nothing."""
    rng = np.random.default_rng(9)
    out = np.zeros(30)
    noise.standard_normal_rows([rng], out, [10], [5])
    assert np.array_equal(out[10:15], np.random.default_rng(9).standard_normal(5))
    assert not out[:10].any() and not out[15:].any()
    noise.standard_normal_rows([], out, [], [])
    assert rng.standard_normal() == np.random.default_rng(9).standard_normal(6)[5]


@pytest.mark.parametrize(("start", "size"), [(-1, 3), (8, 3), (0, 11)])
def test_a_row_outside_the_buffer_is_refused_before_any_draw(start: int, size: int) -> None:
    rng = np.random.default_rng(2)
    out = np.zeros(10)
    with pytest.raises(ValueError, match="outside"):
        noise.standard_normal_rows([rng, rng], out, [0, start], [2, size])
    assert not out.any()
    assert rng.standard_normal() == np.random.default_rng(2).standard_normal()
