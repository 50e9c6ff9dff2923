"""What every command does to the module (protocol.md §3, §9, §10).

Handlers are keyed by the command's *meaning* (:class:`protocol.ids.Command`),
so both numberings (the module's :class:`~protocol.commands.CommandSet`) reach
the same effect. Each handler gets the module, the interface the command came
from, the parsed payload fields and the raw frame (STATE_IF_SETUP needs the
frame's checksum bytes). The command ack is queued by the interface afterwards.
Payload layouts come from :mod:`protocol.commands`; nothing here re-declares a
byte layout.

Choices where the spec is silent (each matches the module's firmware):

* OUTPUT_ALL_OFF switches off this interface's periodic outputs, clears the
  module's conditional output (flag, ids, interface) and empties this
  interface's queue; states already pulled for the next packet stay pending.
* RESET_ZUPT_AIDED_INS (0x33) is 0x34 without the step-wise reset and without
  setting up outputs: it empties the sequence and switches all outputs of its
  interface off (queue emptied, conditional output cleared), as the firmware's
  handler does, but leaves the lossless flag and the step counter alone.
* NORMAL_IMU_WITH_BIAS_EST (0x41) delays its outputs with the conditional
  output and STATE_OUTPUT_IF_COUNTER in slot 5: the periodic outputs switch on
  in the loop whose interrupt count is 128 past the command's.
* SETUP_DEBUG_PROC's interface byte is a mask (1 USB, 2 Bluetooth, 3 both).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from protocol.commands import CommandSpec
from protocol.ids import NR_IMUS, NR_SLOTS, PROC_ID_LIMIT, Command, OutputMode, ProcId, StateId

if TYPE_CHECKING:  # pragma: no cover
    from .context import Mcu as Module
    from .interface import ExternalInterface

#: A command's handler: (the module, the interface the command came on, its decoded payload, its bytes).
Handler = Callable[["Module", "ExternalInterface", Any, bytes], None]
HANDLERS: dict[Command, Handler] = {}

# mode-byte bits as plain ints (IntFlag arithmetic is slow on the per-command path)
_LOSSLESS = int(OutputMode.LOSSLESS)
_PULL = int(OutputMode.PULL)
_INERTIAL = int(OutputMode.INERTIAL)
_TEMPERATURE = int(OutputMode.TEMPERATURE)
_MAGNETOMETER = int(OutputMode.MAGNETOMETER)

#: Loop cycles NORMAL_IMU_WITH_BIAS_EST waits before its outputs start (buffers filled).
BIAS_EST_OUTPUT_DELAY = 128

P = ProcId
#: The MIMU front end: read, preprocess, detect stand-still, estimate bias, convert.
FRONTEND_SEQUENCE = (P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET,
                     P.FRONTEND_BIASEST, P.FRONTEND_CONVCOMP)
#: Running sequence of both INS modes until the initial alignment is done.
ALIGNMENT_SEQUENCE = FRONTEND_SEQUENCE + (P.FRONTEND_INITIAL_ALIGNMENT,)
#: Stored (tracking) sequence of step-wise dead reckoning (0x34).
STEPWISE_SEQUENCE = FRONTEND_SEQUENCE + (P.STEPWISE_SYSTEM_RESET, P.MECHANIZATION, P.TIME_UPDATE,
                                         P.ZUPT_UPDATE, P.STATE_OUTPUT_IF)
#: Stored (tracking) sequence of ZUPT-aided INS (0x33).
ZUPT_INS_SEQUENCE = FRONTEND_SEQUENCE + (P.MECHANIZATION, P.TIME_UPDATE, P.ZUPT_UPDATE)
#: States of one step packet, in the conditional output of 0x34.
STEP_STATES = (StateId.DX, StateId.DP, StateId.STEP_COUNTER)


def handles(*meanings: Command) -> Callable[[Handler], Handler]:
    def register(fn: Handler) -> Handler:
        for m in meanings:
            HANDLERS[m] = fn
        return fn

    return register


def execute(module: Module, iface: ExternalInterface, spec: CommandSpec, raw: bytes) -> None:
    """Run a complete, checksum-verified command frame *raw* received on *iface*."""
    handler = HANDLERS[spec.command]
    fields = spec.parse_payload(raw[1:-2]) if spec.payload_len else None
    handler(module, iface, fields, raw)


# ----------------------------------------------------------------- basics
@handles(Command.ACK)
def _ack(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    iface.queue.ack(f.packet_number)


@handles(Command.PING, Command.GP_TEST)
def _nothing(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    pass


@handles(Command.MCU_ID)
def _mcu_id(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    iface.pull(StateId.MCU_ID)


# ------------------------------------------------------ hardware in the loop
@handles(Command.SETUP_DEBUG_PROC)
def _setup_debug_proc(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    seq = module.sequence
    seq.empty()
    for slot, pid in enumerate(f.proc_ids):
        seq.set_slot(slot, pid)
    seq.set_slot(10, P.STATE_OUTPUT_ONCE_IF)
    seq.set_slot(11, P.STORE_AND_EMPTY_PROC_SEQU)
    module.cond_output.setup(0, f.interface, _PULL, list(f.state_ids), module.clock.interrupts)
    seq.store_and_empty()


@handles(Command.INPUT_IMU_RD)
def _input_imu_rd(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    memory = module.memory
    memory[StateId.IMU_TS][...] = f.timestamp
    memory.imu_raw[:NR_IMUS] = np.asarray(f.imu, dtype=np.int16)
    module.sequence.restore()
    module.cond_output.force(module.interface_list)


# ----------------------------------------------------------------- states
def _set_state(n: int) -> Handler:
    def handler(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
        size = module.memory.size(f.state_id)
        if 0 < size <= n:
            module.memory.write_wire(f.state_id, bytes(f.data[:size]))

    handler.__name__ = f"_set_state_{n}"
    return handler


for _meaning, _n in ((Command.SET_STATE_1, 1), (Command.SET_STATE_4, 4), (Command.SET_STATE_12, 12),
                     (Command.SET_STATE_24, 24), (Command.SET_STATE_48, 48),
                     (Command.SET_STATE_254, 254)):
    HANDLERS[_meaning] = _set_state(_n)


# ---------------------------------------------------------------- outputs
@handles(Command.OUTPUT_STATE)
def _output_state(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    iface.set_lossless(f.mode & _LOSSLESS)
    iface.output(f.state_id, f.mode)


@handles(Command.OUTPUT_MULTIPLE_STATES)
def _output_multiple(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    iface.set_lossless(f.mode & _LOSSLESS)
    for sid in f.state_ids:
        iface.output(sid, f.mode)


def all_outputs_off(module: Module, iface: ExternalInterface) -> None:
    """OUTPUT_ALL_OFF's effect (also the first step of the mode commands)."""
    iface.all_outputs_off()
    module.cond_output.clear(module.clock.interrupts)
    iface.empty_queue()


@handles(Command.OUTPUT_ALL_OFF)
def _output_all_off(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    all_outputs_off(module, iface)


@handles(Command.STATE_IF_SETUP)
def _state_if_setup(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    # quirk (§9): the firmware copies 10 ids; the 9th and 10th are the frame's checksum bytes
    ids = list(f.state_ids) + [raw[-2], raw[-1]]
    module.cond_output.setup(f.flag_id, iface.mask, f.mode, ids, module.clock.interrupts)


@handles(Command.OUTPUT_IMU_RD)
def _output_imu_rd(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    mode = f.mode
    iface.set_lossless(mode & _LOSSLESS)
    sel = f.imu_selector
    for i in range(32):
        if sel >> i & 1:
            if mode & _INERTIAL:
                iface.output(0x40 + i, mode)
            if mode & _TEMPERATURE:
                iface.output(0x60 + i, mode)
            if mode & _MAGNETOMETER:
                iface.output(0x90 + i, mode)
    iface.output(StateId.IMU_TS, mode)


@handles(Command.SET_IMU_BANDWIDTH)
def _set_imu_bandwidth(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    if f.dlpf_cfg < 7:
        module.sensors.set_dlpf(f.dlpf_cfg)
        module.dlpf_cfg = f.dlpf_cfg


# ------------------------------------------------------- process sequence
@handles(Command.RUN_PROC)
def _run_proc(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    if f.proc_id < PROC_ID_LIMIT and f.slot < NR_SLOTS:
        module.sequence.set_slot(f.slot, f.proc_id)


@handles(Command.RUN_MULT_PROC)
def _run_mult_proc(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    for slot, pid in enumerate(f.proc_ids):
        if pid < PROC_ID_LIMIT:
            module.sequence.set_slot(slot, pid)


@handles(Command.ALL_PROC_OFF)
def _all_proc_off(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.sequence.empty()


@handles(Command.RESET_PROC_SETUP)
def _reset_proc_setup(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.restore_if_flag = f.flag_id


@handles(Command.STORE_AND_EMPTY)
def _store_and_empty(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.sequence.store_and_empty()


@handles(Command.RESTORE_PROC_SEQU)
def _restore(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.sequence.restore()


# ---------------------------------------------------------- mode commands
def _start_ins(module: Module, stored: tuple[int, ...]) -> None:
    seq = module.sequence
    seq.empty()
    seq.set_storage(stored)
    seq.set_slots(ALIGNMENT_SEQUENCE)
    seq.set_slot(NR_SLOTS - 1, P.RESTORE_PROC_SEQU_IF)
    module.memory.clear_flag(StateId.INIT_DONE)
    module.restore_if_flag = StateId.INIT_DONE


@handles(Command.RESET_ZUPT_AIDED_INS)
def _zupt_aided_ins(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.sequence.empty()
    all_outputs_off(module, iface)
    _start_ins(module, ZUPT_INS_SEQUENCE)


@handles(Command.STEPWISE_DEAD_RECKONING)
def _stepwise_dead_reckoning(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    module.sequence.empty()
    all_outputs_off(module, iface)
    iface.set_lossless(True)
    module.memory[StateId.STEP_COUNTER][...] = 0
    _start_ins(module, STEPWISE_SEQUENCE)
    module.cond_output.setup(StateId.FILTER_RESET_FLAG, iface.mask, _PULL, list(STEP_STATES),
                             module.clock.interrupts)


@handles(Command.MIMU_FRONTEND)
def _mimu_frontend(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    seq = module.sequence
    seq.empty()
    seq.set_slots(FRONTEND_SEQUENCE)


def _plain_imu_mode(module: Module, iface: ExternalInterface, mode: int, slots: tuple[int, ...]) -> None:
    """What both plain IMU modes do first: outputs off, lossless flag from *mode*, sequence = *slots*."""
    all_outputs_off(module, iface)
    iface.set_lossless(mode & _LOSSLESS)
    seq = module.sequence
    seq.empty()
    seq.set_slots(slots)


@handles(Command.NORMAL_IMU)
def _normal_imu(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    _plain_imu_mode(module, iface, f.mode, (P.READ_INERTIAL, P.FRONTEND_PREPROC))
    iface.output(StateId.IMU_TS, f.mode)
    iface.output(StateId.U_K, f.mode)


@handles(Command.NORMAL_IMU_WITH_BIAS_EST)
def _normal_imu_with_bias_est(module: Module, iface: ExternalInterface, f: Any, raw: bytes) -> None:
    _plain_imu_mode(module, iface, f.mode, FRONTEND_SEQUENCE + (P.STATE_OUTPUT_IF_COUNTER,))
    module.cond_output.setup(0, iface.mask, f.mode, [StateId.IMU_TS, StateId.U_K],
                             module.clock.interrupts, BIAS_EST_OUTPUT_DELAY)


_missing = [c for c in Command if c not in HANDLERS]
assert not _missing, f"commands without a handler: {_missing}"
