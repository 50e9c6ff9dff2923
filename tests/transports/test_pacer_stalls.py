"""The pacer's real-time priority and what it reports of the stalls it cannot help: the run queue, the GC."""

from __future__ import annotations

import gc
import os

import pytest

from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import MultiPacer, Pacer
from firmware_sim.transports.pacer.priority import raise_priority
from firmware_sim.transports.pacer.stalls import GcPauses, run_queue_wait_s


@pytest.mark.parametrize("level", [0, 100, -1])
def test_a_real_time_level_outside_1_to_99_is_refused(level):
    with pytest.raises(ValueError, match="from 1 to 99"):
        MultiPacer([Pacer(build_module())], rt_priority=level)


def test_no_level_leaves_the_thread_as_it_is():
    before = os.sched_getscheduler(0)
    assert raise_priority(None) == "normal"
    assert os.sched_getscheduler(0) == before


def test_a_loop_run_in_the_caller_s_thread_hands_it_back_at_the_ordinary_priority():
    pacer = Pacer(build_module(), speed=1.0)
    pacer.group.rt_priority = 5
    pacer.run(duration_s=0.02)  # blocks in this thread, which it may have raised
    st = pacer.status()
    assert st.priority == "SCHED_FIFO 5" or st.priority.startswith("normal ("), st.priority
    assert os.sched_getscheduler(0) == os.SCHED_OTHER
    assert st.run_queue_wait_s is None  # known only while the loop runs


def test_a_loop_as_fast_as_possible_never_takes_the_real_time_priority():
    pacer = Pacer(build_module(), speed=0)
    pacer.group.rt_priority = 5
    pacer.run(duration_s=0.02)
    assert pacer.status().priority == "normal"


def test_the_run_queue_wait_of_a_running_thread_is_known_and_of_no_thread_not():
    import threading

    waited = run_queue_wait_s(threading.get_native_id())
    assert waited is None or waited >= 0.0  # None where Linux's schedstat is missing
    assert run_queue_wait_s(None) is None


def test_collections_are_counted_only_while_watched():
    pauses = GcPauses()
    pauses.watch()
    try:
        gc.collect()
    finally:
        pauses.unwatch()
    gc.collect()
    assert pauses.count == 1 and pauses.longest > 0.0 and pauses.longest_generation == 2


def test_a_thread_pinned_to_a_cpu_runs_there_and_no_cpu_leaves_it_anywhere():
    from firmware_sim.transports.pacer.priority import allowed_cpus, pin_to_cpu

    anywhere = allowed_cpus()
    assert pin_to_cpu(None) == "any CPU"
    try:
        cpu = max(anywhere)
        assert pin_to_cpu(cpu) == f"CPU {cpu}"
        assert os.sched_getaffinity(0) == {cpu}
    finally:
        os.sched_setaffinity(0, anywhere)
