import os
import threading

import pytest

from bayescal import forked


@pytest.fixture
def alone(monkeypatch):
    """No other thread in this process, whatever the test runner and BLAS start."""
    monkeypatch.setattr(forked, "_single_threaded", lambda: True)


def test_the_pieces_come_back_in_order_from_forked_workers_that_never_pickle_the_work(alone):
    lock = threading.Lock()  # not picklable: the work reaches the workers by the fork alone
    parent = os.getpid()

    def work(index):
        with lock:
            return index * index, os.getpid() != parent

    results = list(forked.forked_map(work, 5, 2))
    assert [square for square, _ in results] == [0, 1, 4, 9, 16]
    assert all(in_worker for _, in_worker in results)
    assert forked._FORKED == []


def test_one_worker_runs_the_pieces_in_this_process(alone):
    parent = os.getpid()
    assert list(forked.forked_map(lambda index: (index, os.getpid()), 3, 1)) == [(0, parent), (1, parent), (2, parent)]


def test_an_error_in_a_worker_reaches_the_caller_and_the_workers_end(alone):
    def work(index):
        if index == 2:
            raise ValueError("piece 2")
        return index

    with pytest.raises(ValueError, match="piece 2"):
        list(forked.forked_map(work, 4, 2))
    assert forked._FORKED == []


def test_workers_follow_the_pieces_the_request_and_the_threads(monkeypatch):
    monkeypatch.setattr(forked, "_single_threaded", lambda: True)
    assert forked._workers(1, 4) == 1
    assert forked._workers(9, 1) == 1
    assert forked._workers(3, 4) == 3
    assert forked._workers(9, 2) == 2
    monkeypatch.setattr(forked, "_single_threaded", lambda: False)
    assert forked._workers(3, 4) == 1


def test_threads_are_counted_as_the_system_counts_them():
    import threading

    alone = forked._single_threaded()
    started, stop = threading.Event(), threading.Event()
    worker = threading.Thread(target=lambda: (started.set(), stop.wait()))
    worker.start()
    started.wait()
    try:
        assert not forked._single_threaded()
    finally:
        stop.set()
        worker.join()
    assert forked._single_threaded() == alone


def test_the_cores_are_those_this_process_may_run_on(monkeypatch):
    monkeypatch.setattr(forked.os, "sched_getaffinity", lambda pid: {0, 3})
    assert forked.available_cores() == 2
