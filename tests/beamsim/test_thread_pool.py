"""The pool that runs a batch's items (points, shares of copies) on threads."""

import threading

import pytest

from beamsim.kernels.thread_pool import run_items


@pytest.mark.parametrize("threads", [1, 2, 5])
def test_every_item_runs_once(threads):
    seen, lock = [], threading.Lock()

    def kernel(tag, i):
        with lock:
            seen.append((tag, i))

    run_items(kernel, ("x",), [4, 1, 7, 2], threads)
    assert sorted(seen) == [("x", 1), ("x", 2), ("x", 4), ("x", 7)]
    run_items(kernel, ("y",), [], threads)
    assert len(seen) == 4


def test_an_item_that_raises_is_raised_by_the_call():
    def kernel(i):
        if i == 3:
            raise FloatingPointError("item 3")

    with pytest.raises(FloatingPointError, match="item 3"):
        run_items(kernel, (), range(6), 2)


def test_the_item_kernels_release_the_gil():
    """Without ``nogil`` the pool's threads would take turns: the batches would run on one
    core whatever ``n_threads`` says (their results would not show it)."""
    from beamsim.kernels import copies, expo, newmark, rk4

    for kernel in (rk4.run_point, rk4.run_point_rigid, expo.run_point, newmark.run_point,
                   copies.run_task, copies.run_task_rigid):
        assert kernel.targetoptions.get("nogil") is True, kernel


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_each_thread_has_its_own_per_thread_object(threads):
    """``per_thread``: a thread's calls get its own entry, and no entry is in two calls at once
    (expo's pattern caches must never be filled by two points together)."""
    import time

    busy, seen, lock = set(), [], threading.Lock()

    def kernel(tag, mine, i):
        with lock:
            assert mine not in busy
            busy.add(mine)
            seen.append((i, mine, threading.get_ident()))
        time.sleep(0.002)
        with lock:
            busy.discard(mine)

    run_items(kernel, ("x",), range(12), threads, per_thread=[f"cache{w}" for w in range(threads)])
    assert sorted(i for i, _, _ in seen) == list(range(12))
    owner = {}
    for _, mine, ident in seen:
        assert owner.setdefault(mine, ident) == ident  # an entry stays with its thread
    with pytest.raises(ValueError, match="per_thread"):
        run_items(kernel, ("x",), range(4), 2, per_thread=["only one"])
