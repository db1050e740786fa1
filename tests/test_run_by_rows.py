"""``heading.run_by_rows``: every row once, the caller's range included, errors after all ranges."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.energy import heading


@pytest.fixture(params=[1, 2, 3])
def cores(request, monkeypatch):
    monkeypatch.setattr(heading, "usable_cores", lambda: request.param)
    return request.param


@settings(max_examples=30, deadline=None)
@given(rows=st.integers(1, 50), n=st.integers(1, 4))
def test_every_row_is_written_once(rows, n):
    own = heading.usable_cores
    heading.usable_cores = lambda: n
    try:
        seen = np.zeros(rows, int)

        def fn(a, b):
            seen[a:b] += 1

        heading.run_by_rows(fn, rows)
    finally:
        heading.usable_cores = own
    assert (seen == 1).all()


def test_the_caller_takes_a_range_and_helpers_are_kept(cores):
    names = []
    for _ in range(3):
        heading.run_by_rows(lambda a, b: names.append(threading.current_thread().name), 12)
    assert names.count(threading.current_thread().name) == 3  # one range per call
    helpers = {n for n in names if n != threading.current_thread().name}
    assert len(helpers) <= cores - 1  # the same threads serve every call


def test_a_call_from_a_row_thread_runs_inline(cores):
    """A range that itself splits rows does not wait for its own busy pool."""
    out = np.zeros(8, int)

    def inner(a, b):
        heading.run_by_rows(lambda c, d: out.__setitem__(slice(a + c, a + d), 1), b - a)

    heading.run_by_rows(inner, 8)
    assert out.all()


def test_an_error_is_raised_after_every_range_ended(cores):
    done = []

    def fn(a, b):
        if a == 0:
            raise ValueError("row 0")
        done.append((a, b))

    with pytest.raises(ValueError, match="row 0"):
        heading.run_by_rows(fn, 9)
    assert sorted(done) == [(9 * k // cores, 9 * (k + 1) // cores) for k in range(1, cores)]
