"""What the module is set up to send us: which states may appear in packets, and lossless mode.

A state packet's payload is the raw bytes of the states due in that loop cycle,
in ascending id order, without their ids (protocol.md §6). To split it the host
must know which states it asked for; :class:`OutputPlan` follows the commands
the host sends (protocol.md §3, §5, quirks §9) and, for one packet, finds the
subset of those states whose sizes add up to the payload length.

Effects are applied in two phases, because in lossless mode a command's ack may
wait behind unacknowledged data: when a command is *sent*, the states it may
turn on become candidates at once and lossless mode is assumed on if the command
turns it on (acking a lossy module is harmless, missing acks stalls a lossless
one); when the module *acknowledges* it, the exact new set and flag take effect.

A packet whose length several subsets of those states fit is split as the
conditional output (0x34, STATE_IF_SETUP) when that fits it: the module sends
the conditional states together, all those that exist on it — a real module
has none of the emulator's extension states (:data:`protocol.extensions.EXTENSION_STATES`),
so the conditional set without them fits too. This is what tells IMU_TS riding
along by the checksum quirk from SWING_TIME (both 4 bytes) on a real module,
which sends the first and not the second.

Failing that, it is split as the periodic outputs (OUTPUT_STATE, OUTPUT_MULTIPLE_STATES with a
rate), all of them, or as those and the conditional states together. States switched on at one
rate fire together, and the firmware starts a slower output in step with the faster ones
(protocol.md §5), so a periodic packet carries them all; in the cycle of a step the firmware puts
the step's pulled states in the same packet (§6). This is how the magnetometer stream of the
in-situ calibration (:data:`protocol.extensions.MAG_STREAM_START`: the quaternion and three
magnetometers, a subset of the fusion step packet's states) is told from a step packet and from
other subsets of the same size (DX and QUATERNION are both 16 bytes). Switching a periodic
output off leaves the states the conditional output sends in the candidates.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from protocol.codec import STEP_IDS
from protocol.extensions import EXTENSION_STATES
from protocol.ids import (
    IMU_MAG_BASE,
    IMU_RAW_BASE,
    IMU_TEMP_BASE,
    NR_IMUS,
    Command,
    OutputMode,
    StateId,
)
from protocol.states import STATES

__all__ = ["STEP_STATES", "OutputPlan", "match_layout"]

#: The states of a step packet (0x34 sets this conditional output up).
STEP_STATES: frozenset[int] = frozenset({StateId.DX, StateId.DP, StateId.STEP_COUNTER})


#: An :class:`_Effect` that leaves the conditional output as it is.
_UNCHANGED: tuple[int, ...] = (-1,)


@dataclass(frozen=True)
class _Effect:
    outputs: frozenset[int]
    lossless: bool | None  # None: unchanged
    restart_steps: bool = False
    conditional: tuple[int, ...] | None = _UNCHANGED  # the conditional output's states; None: off
    periodic: frozenset[int] | None = None  # the periodic outputs' states; None: unchanged


class OutputPlan:
    """The host's model of one interface's output set-up on the module.

    ``outputs`` is the set of state ids the module was told to send (confirmed
    by acks); ``candidates`` adds those of commands still awaiting their ack.
    ``lossless`` is True when the module is (or may be about to be) in lossless
    mode, False when known lossy, None when unknown (attached to a running module).
    """

    def __init__(self, outputs: frozenset[int] = STEP_STATES, lossless: bool | None = None):
        self.outputs: frozenset[int] = frozenset(outputs)
        self.lossless: bool | None = lossless
        #: the states of the conditional output (ascending), None when it is off or unknown
        self.conditional: tuple[int, ...] | None = tuple(sorted(outputs)) if outputs == STEP_STATES else None
        #: the states on periodic output (confirmed by acks)
        self.periodic: frozenset[int] = frozenset()
        self._pending: dict[int, _Effect] = {}

    @property
    def candidates(self) -> frozenset[int]:
        out = set(self.outputs)
        for eff in self._pending.values():
            out |= eff.outputs
        return frozenset(out)

    def sent(self, meaning: Command, wire_id: int, fields: dict[str, Any], frame: bytes) -> bool:
        """Note a command the host sent; True if it restarts the step counter (0x34)."""
        eff = self._effect(meaning, fields, frame)
        if eff is None:
            return False
        self._pending[wire_id] = eff
        if eff.lossless:
            self.lossless = True
        return eff.restart_steps

    def awaiting(self, wire_id: int) -> bool:
        """True while a command with this wire id was sent and its ack has not come."""
        return wire_id in self._pending

    def acked(self, wire_id: int) -> None:
        """The module acknowledged the command with this wire id: its effect is now fact."""
        eff = self._pending.pop(wire_id, None)
        if eff is None:
            return
        self.outputs = eff.outputs
        if eff.lossless is not None:
            self.lossless = eff.lossless
        if eff.conditional is not _UNCHANGED:
            self.conditional = eff.conditional
        if eff.periodic is not None:
            self.periodic = eff.periodic

    def _effect(self, meaning: Command, f: dict[str, Any], frame: bytes) -> _Effect | None:
        cur = set(self.outputs)
        if meaning is Command.STEPWISE_DEAD_RECKONING:
            return _Effect(STEP_STATES, True, restart_steps=True, conditional=tuple(sorted(STEP_STATES)),
                           periodic=frozenset())
        if meaning in (Command.OUTPUT_ALL_OFF, Command.RESET_ZUPT_AIDED_INS):
            return _Effect(frozenset(), None, conditional=None, periodic=frozenset())
        if meaning is Command.MCU_ID:
            return _Effect(frozenset(cur | {StateId.MCU_ID}), None)
        if meaning in (Command.OUTPUT_STATE, Command.OUTPUT_MULTIPLE_STATES):
            ids = [f["state_id"]] if meaning is Command.OUTPUT_STATE else [i for i in f["state_ids"] if i]
            return self._output(cur, ids, f["mode"])
        if meaning is Command.STATE_IF_SETUP:
            # Quirk §9: the firmware reads 10 ids, the 8 given and the frame's checksum bytes.
            ck = frame[-2:]
            ids = [i for i in list(f["state_ids"]) + list(ck) if i in STATES]
            return _Effect(frozenset(cur | set(ids)), None, conditional=tuple(sorted(set(ids))))
        if meaning is Command.OUTPUT_IMU_RD:
            mode = f["mode"]
            ids = {StateId.IMU_TS}
            for i in range(NR_IMUS):
                if f["imu_selector"] >> i & 1:
                    if mode & OutputMode.INERTIAL:
                        ids.add(IMU_RAW_BASE + i)
                    if mode & OutputMode.TEMPERATURE:
                        ids.add(IMU_TEMP_BASE + i)
                    if mode & OutputMode.MAGNETOMETER:
                        ids.add(IMU_MAG_BASE + i)
            return self._output(cur, sorted(ids), mode)
        if meaning in (Command.NORMAL_IMU, Command.NORMAL_IMU_WITH_BIAS_EST):
            mode = f["mode"]
            ids = frozenset({StateId.IMU_TS, StateId.U_K})
            return _Effect(ids, bool(mode & OutputMode.LOSSLESS), conditional=None,
                           periodic=ids if mode & OutputMode.RATE_MASK and not mode & OutputMode.PULL
                           else frozenset())
        if meaning is Command.SETUP_DEBUG_PROC:
            ids = [i for i in f["state_ids"] if i in STATES]
            return _Effect(frozenset(cur | set(ids)), None, conditional=tuple(sorted(set(ids))))
        return None

    def _output(self, cur: set[int], ids: list[int], mode: int) -> _Effect:
        """OUTPUT_STATE and its relatives: *ids* pulled, or on periodic output at the mode's rate,
        or off (rate 0); the lossless flag from the mode (protocol.md §9)."""
        ids = [i for i in ids if i in STATES]
        lossless = bool(mode & OutputMode.LOSSLESS)
        if mode & OutputMode.PULL:
            return _Effect(frozenset(cur | set(ids)), lossless)
        if mode & OutputMode.RATE_MASK:
            return _Effect(frozenset(cur | set(ids)), lossless, periodic=self.periodic | set(ids))
        # off: a state the conditional output sends stays a candidate
        gone = set(ids) - set(self.conditional or ())
        return _Effect(frozenset(cur - gone), lossless, periodic=self.periodic - set(ids))

    def layout(self, payload_len: int) -> tuple[int, ...] | None:
        """The state ids (ascending) in a packet with this payload length: the one subset of the
        candidates that fits, else the conditional output if it fits (with or without the
        extension states), else the periodic outputs, alone or with the conditional output, else
        the plain step packet 0x34 sets up if it fits, else None."""
        ids = match_layout(self.candidates, payload_len)
        if ids is not None:
            return ids
        tries: list[tuple[int, ...]] = []
        if self.conditional is not None:
            tries += [self.conditional, tuple(i for i in self.conditional if i not in EXTENSION_STATES)]
        if self.periodic:
            with_steps = self.periodic | set(self.conditional or ())
            tries += [tuple(sorted(self.periodic)), tuple(sorted(with_steps))]
        if self.conditional is not None:
            tries.append(STEP_IDS)
        for layout in tries:
            if set(layout) <= self.candidates and sum(STATES[i].size for i in layout) == payload_len:
                return layout
        return None

    def __repr__(self) -> str:
        ids = " ".join(f"{i:02X}" for i in sorted(self.outputs))
        periodic = " ".join(f"{i:02X}" for i in sorted(self.periodic))
        return (f"OutputPlan(outputs=[{ids}], periodic=[{periodic}], lossless={self.lossless}, "
                f"pending={len(self._pending)})")


@lru_cache(maxsize=1024)
def match_layout(candidates: frozenset[int], payload_len: int) -> tuple[int, ...] | None:
    """The unique subset of *candidates* whose state sizes sum to *payload_len*, ascending.

    None if no subset or more than one fits (the packet cannot be split safely).
    """
    ids = sorted(i for i in candidates if i in STATES)
    sizes = [STATES[i].size for i in ids]
    n = len(ids)
    # ways[k][r]: number of subsets (capped at 2) of ids[k:] summing to r.
    ways = [[0] * (payload_len + 1) for _ in range(n + 1)]
    ways[n][0] = 1
    for k in range(n - 1, -1, -1):
        row, nxt, s = ways[k], ways[k + 1], sizes[k]
        for r in range(payload_len + 1):
            w = nxt[r] + (nxt[r - s] if r >= s else 0)
            row[r] = 2 if w > 2 else w
    if ways[0][payload_len] != 1:
        return None
    out, r = [], payload_len
    for k in range(n):
        if ways[k + 1][r] == 1:
            continue  # the unique subset does not use ids[k]
        out.append(ids[k])
        r -= sizes[k]
    return tuple(out)
