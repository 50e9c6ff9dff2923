"""Process sequence, processing functions 0x01–0x07 and 0x13, virtual clock and overruns."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.mcu.clock import Clock
from firmware_sim.mcu.firmware import RUNTIME_ONLY
from firmware_sim.mcu.imu_bus import ScriptedSource, still_board
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.mcu.sequence import FunctionTable, ProcessSequence, processing_function
from firmware_sim.nav.firmware import OPENSHOE, build_module
from firmware_sim.nav.inertial import READ_INERTIAL_CYCLES
from protocol.ids import NR_IMUS, ProcId, StateId

from .emu import Host


# ------------------------------------------------------------------ sequence
def test_unknown_id_empties_the_slot():
    seq = ProcessSequence(OPENSHOE.functions)
    seq.set_slot(0, ProcId.READ_INERTIAL)
    seq.set_slot(0, 0x2F)
    assert seq.slots[0] == 0


def test_function_replacing_the_sequence_mid_run_follows_the_live_slots(temp_functions):
    log: list[str] = []

    def replace(m: Module) -> None:
        log.append("A")
        m.sequence.empty()
        m.sequence.set_slot(1, 0x2B)
        m.sequence.set_slot(5, 0x2C)

    temp_functions(0x2A, replace)
    temp_functions(0x2B, lambda m: log.append("B"))
    temp_functions(0x2C, lambda m: log.append("C"))
    m = build_module()
    m.sequence.set_slot(2, 0x2A)
    m.sequence.set_slot(7, 0x2B)
    m.step()
    assert log == ["A", "C"]  # later slot 5 of the new sequence runs now; slot 1 and old slot 7 do not
    log.clear()
    m.step()
    assert log == ["B", "C"]


def test_store_and_empty_stops_the_rest_of_the_sequence(temp_functions):
    log = []
    temp_functions(0x2A, lambda m: log.append(1))
    m = build_module()
    m.sequence.set_slots([0x2A, ProcId.STORE_AND_EMPTY_PROC_SEQU, 0x2A])
    m.step()
    assert log == [1] and m.sequence.slots == [0] * 12
    assert m.sequence.storage[:3] == [0x2A, ProcId.STORE_AND_EMPTY_PROC_SEQU, 0x2A]


def test_ps_dt_holds_the_modelled_cost_of_each_slot(temp_functions):
    temp_functions(0x2A, lambda m: None, cycles=1234)
    m = build_module()
    m.sequence.set_slots([0x2A, 0, ProcId.READ_INERTIAL])
    m.step()
    call = m.costs.slot_call
    assert int(m.memory[0x80]) == 1234 + call
    assert int(m.memory[0x81]) == 0
    assert int(m.memory[0x82]) == READ_INERTIAL_CYCLES + call
    assert m.firmware.functions.budget(m.sequence.slots, call) == 1234 + READ_INERTIAL_CYCLES + 2 * call
    # the loop's GP_DT includes them
    assert int(m.memory[StateId.GP_DT]) > 1234 + READ_INERTIAL_CYCLES


def test_cost_table_lists_every_function_of_the_firmware():
    table = OPENSHOE.functions.cost_table()
    assert [pid for pid, _, _ in table] == sorted(OPENSHOE.functions)
    assert (0x13, "READ_INERTIAL", READ_INERTIAL_CYCLES) in table


def test_a_table_refuses_two_functions_with_one_id():
    def one(m: Module) -> None:
        pass

    def another(m: Module) -> None:
        pass

    processing_function(0x2A, cycles=1)(one)
    processing_function(0x2A, cycles=1)(another)
    with pytest.raises(ValueError, match="declared twice"):
        FunctionTable.of(one, another)
    assert FunctionTable.of(one).with_functions(another)[0x2A].fn is another, "linking in replaces"
    with pytest.raises(ValueError):
        processing_function(0x30, cycles=1)
    with pytest.raises(TypeError, match="not declared"):
        FunctionTable.of(lambda m: None)


def test_the_runtime_alone_knows_no_navigation():
    """Without the navigation firmware the tracking commands leave the slots empty (unknown ids)."""
    m = Module(firmware=RUNTIME_ONLY)
    m.usb.port.host_write(bytes.fromhex("34 00 34"))
    m.run(3)
    assert m.usb.port.host_read() == bytes.fromhex("A0 34 00 D4")
    assert m.sequence.slots[:6] == [0] * 6 and m.sequence.slots[11] == ProcId.RESTORE_PROC_SEQU_IF


def test_work_state_is_created_once_per_module():
    m1, m2 = build_module(), build_module()
    a = m1.work("x", lambda: np.zeros(3))
    a[0] = 5
    assert m1.work("x", lambda: np.ones(3))[0] == 5
    assert m2.work("x", lambda: np.ones(3))[0] == 1


# ----------------------------------------------------------- utility functions
def test_empty_and_restore_functions():
    m = build_module()
    m.sequence.storage[:2] = [ProcId.STATE_OUTPUT_IF, ProcId.STATE_OUTPUT_IF]
    m.sequence.set_slot(4, ProcId.RESTORE_PROC_SEQU)
    m.step()
    assert m.sequence.slots[:2] == [5, 5] and m.sequence.slots[4] == 0
    m.sequence.set_slot(3, ProcId.EMPTY_PROCESS_SEQUENCE)
    m.step()
    assert m.sequence.slots == [0] * 12


def test_state_output_once_if_clears_its_flag():
    h = Host()
    m = h.module
    m.cond_output.setup(StateId.GP_ID, 1, 0x20, [StateId.INTERRUPT_COUNTER], m.clock.interrupts)
    m.sequence.set_slot(0, ProcId.STATE_OUTPUT_ONCE_IF)
    m.memory[StateId.GP_ID][...] = 1
    assert len(h.step()) == 10
    assert not m.memory.flag(StateId.GP_ID)
    assert h.step(3) == b""


def test_state_output_if_counter_fires_once_n_loops_after_setup():
    h = Host()
    m = h.module
    m.cond_output.setup(0, 1, 0x20, [StateId.INTERRUPT_COUNTER], m.clock.interrupts, wait_cycles=10)
    m.sequence.set_slot(0, ProcId.STATE_OUTPUT_IF_COUNTER)
    outs = h.per_tick(30)
    assert [i for i, o in enumerate(outs) if o] == [9]
    assert int.from_bytes(outs[9][4:8], "big") == 10


def test_conditional_output_with_a_rate_switches_periodic_output_on():
    h = Host()
    m = h.module
    m.cond_output.setup(StateId.GP_ID, 1, 0x02, [StateId.GP_DT], m.clock.interrupts)
    m.sequence.set_slot(0, ProcId.STATE_OUTPUT_IF)
    m.memory[StateId.GP_ID][...] = 1
    h.step()
    assert h.iface.periodic_outputs == {StateId.GP_DT: 2}
    assert not h.iface.lossless


# --------------------------------------------------------------- READ_INERTIAL
def script(n: int) -> np.ndarray:
    s = np.arange(n * NR_IMUS * 6, dtype=np.int16).reshape(n, NR_IMUS, 6)
    return s


def test_read_inertial_delays_the_accelerometer_by_one_sample():
    s = script(4)
    m = build_module(sensors=ScriptedSource(s, temp=-40, mag=(1, 2, 3)))
    m.sequence.set_slot(0, ProcId.READ_INERTIAL)
    for k in range(4):
        m.step()
        raw = m.memory.imu_raw[:NR_IMUS]
        assert (raw[:, 3:6] == s[k, :, 3:6]).all()
        assert (raw[:, 0:3] == s[max(k - 1, 0), :, 0:3]).all()
    assert (m.memory.imu_temp[:NR_IMUS] == -40).all()
    assert (m.memory.imu_mag[:NR_IMUS] == [1, 2, 3]).all()
    assert (m.memory.imu_raw[NR_IMUS:] == 0).all()


def test_imu_timestamp_is_the_cycle_counter_at_the_read_and_wraps():
    start = 2**32 - 3 * 64_000
    m = build_module(ModuleConfig(start_cycles=start))
    m.sequence.set_slot(0, ProcId.READ_INERTIAL)
    stamps = []
    for _ in range(5):
        m.step()
        stamps.append(int(m.memory[StateId.IMU_TS]))
    diffs = [(b - a) % 2**32 for a, b in zip(stamps[:-1], stamps[1:], strict=True)]
    assert diffs == [64_000] * 4  # modulo 2^32 across the wrap
    assert stamps[-1] < stamps[0]
    assert m.clock.now_cycles > 2**32


def test_exhausted_source_sets_the_flag_and_writes_nothing():
    m = build_module(sensors=ScriptedSource(script(2), finite=True))
    m.sequence.set_slot(0, ProcId.READ_INERTIAL)
    m.run(2)
    assert not m.sensors_exhausted
    before = m.memory.imu_raw.copy()
    m.step()
    assert m.sensors_exhausted and (m.memory.imu_raw == before).all()


def test_empty_sequence_reads_nothing():
    src = ScriptedSource(script(3))
    m = build_module(sensors=src)
    m.run(3)
    assert (m.memory.imu_raw == 0).all()


def test_default_source_is_a_board_at_rest():
    s = still_board().read(0)
    assert s.imu[0].tolist() == [0, 0, -2048, 0, 0, 0]
    assert s.imu[2].tolist() == [0, 0, 2048, 0, 0, 0]  # bottom chips are upside down


# ----------------------------------------------------------------------- clock
def test_clock_rates_and_tick_lengths():
    assert Clock(1000).cycles_per_tick == 64_000
    assert Clock(250).cycles_per_tick == 256_000
    with pytest.raises(ValueError):
        Clock(3)  # 64e6 / 3 is not whole


def test_overrun_starts_the_next_loop_at_once_and_counts_missed_ticks(temp_functions):
    temp_functions(0x2A, lambda m: None, cycles=150_000)
    m = build_module()
    m.sequence.set_slot(0, 0x2A)
    m.step()  # 64 000 .. > 214 000
    assert m.clock.overruns == 0
    end = m.clock.now_cycles
    m.step()
    assert m.clock.loop_start == end  # started at once
    assert m.clock.overruns == 1 and m.clock.missed_ticks == 1  # ticks at 128k and 192k: one loop
    assert m.clock.interrupts == 3 and m.clock.ticks == 2
    assert int(m.memory[StateId.INTERRUPT_COUNTER]) == 3
    assert int(m.memory[StateId.GP_DT]) > 150_000


def test_loops_fit_a_tick_without_overrun_in_normal_use():
    m = build_module()
    m.sequence.set_slot(0, ProcId.READ_INERTIAL)
    m.run(100)
    assert m.clock.overruns == 0
    assert m.clock.now_cycles < 101 * 64_000


def test_boot_hooks_run_before_initial_states():
    def hook(m: Module) -> None:
        m.memory[StateId.GP_ID][...] = 7
        m.memory[StateId.TH_ZARU][...] = 99

    m = build_module(ModuleConfig(initial_states={StateId.TH_ZARU: 5}),
                     firmware=OPENSHOE.with_boot_hooks(hook))
    assert int(m.memory[StateId.GP_ID]) == 7 and int(m.memory[StateId.TH_ZARU]) == 5


def test_the_tracking_sequences_fit_one_tick_at_1khz():
    """With the documented costs, step-wise tracking must not overrun (DT would jitter)."""
    from firmware_sim.mcu.command_handlers import ALIGNMENT_SEQUENCE, STEPWISE_SEQUENCE, ZUPT_INS_SEQUENCE

    m = build_module()
    c = m.costs
    fixed = c.loop_overhead + 2 * c.rx_poll + c.tx_scan + 64 * (c.tx_per_byte + c.tx_write_per_byte)
    for seq in (ALIGNMENT_SEQUENCE, STEPWISE_SEQUENCE, ZUPT_INS_SEQUENCE):
        assert m.firmware.functions.budget(seq, c.slot_call) + fixed < m.clock.cycles_per_tick


def test_module_budget_shows_whether_the_running_sequence_fits(temp_functions):
    temp_functions(0x2A, lambda m: None, cycles=70_000)
    m = build_module()
    m.sequence.set_slot(0, ProcId.READ_INERTIAL)
    b = m.budget()
    assert b["tick"] == 64_000 and b["slots"] == READ_INERTIAL_CYCLES + m.costs.slot_call
    assert b["free"] > 0
    m.sequence.set_slot(1, 0x2A)
    assert m.budget()["free"] < 0
    m.run(3)
    assert m.clock.overruns > 0  # and the clock reports it
