"""The host's side of the protocol as a pure state machine: bytes in, events and acks out.

:class:`HostSession` does everything the host must do with the module's byte
stream, without any I/O, so it can be tested byte by byte:

* split the stream into command acks and state packets
  (:class:`protocol.stream.StreamDecoder`; garbage skipped and counted);
* acknowledge **every** state packet while the module is (or may be) in lossless
  mode — resends too, since the module repeats the oldest packet every 128 loop
  cycles until it sees ``01 nn nn ck ck`` with its number (protocol.md §6);
* suppress resends: in lossless mode only the oldest packet is sent, so a resend
  carries the same number as the packet just before it (stop-and-wait);
* split each new packet into its states (:class:`hostlib.link.outputs.OutputPlan`),
  recognise steps, sum them (:class:`hostlib.track.steps.StepTracker`) with their
  swing time when the packet carries one (state 0x34 SWING_TIME, after
  :data:`protocol.extensions.FUSION_SETUP`), report step-counter gaps;
* note the module's serial number when a packet carries it (state 0x04 MCU_ID).

Replaying a capture, the session sees only the module's bytes: *implied_commands*
tells it which commands the capture's host sent, so that the module's ack of one
has that command's effect on the expected outputs (:mod:`hostlib.files.replay`). A host
may send several commands with one wire id (the magnetometer stream on, later off):
the acks of that id stand for them in the order given.

The events it reports are declared in :mod:`hostlib.events`.

``feed(chunk) -> (events, bytes_to_send)``: a thread (or anything else) only
moves bytes between the port and this object.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from protocol.codec import PayloadError, Step, decode_states
from protocol.commands import CommandSet
from protocol.commands import command_set as _command_set
from protocol.frames import CommandAck, StatePacket, build_command, build_packet_ack
from protocol.ids import Command, StateId
from protocol.stream import StreamDecoder

from ..errors import NotSupportedByCommandSet
from ..events import CommandAckEvent, PacketEvent, StepEvent, StepOutcome, StreamEvent
from ..track.steps import StepTracker
from .outputs import OutputPlan

__all__ = [
    "AckPolicy",
    "HostSession",
    "SessionStats",
]

#: When to acknowledge state packets: "auto" (while the module may be lossless,
#: or when a resend or a step shows it is), "always", or "never".
AckPolicy = str


@dataclass
class SessionStats:
    """Counters of everything the session saw; nothing is dropped without being counted here."""

    bytes_received: int = 0
    garbage_bytes: int = 0  #: bytes skipped between frames
    bad_frames: int = 0  #: frames with a bad checksum or length
    command_acks: int = 0
    packets: int = 0  #: new state packets
    duplicate_packets: int = 0  #: resends of the previous packet (acked again, not reported)
    packet_number_jumps: int = 0  #: new packets whose number was not previous + 1
    acks_sent: int = 0  #: packet acks produced
    undecoded_packets: int = 0  #: payloads that no unique set of requested states fits
    steps: int = 0  #: steps summed
    rejected_steps: int = 0  #: steps left out: numbers not finite, or dP no covariance (an event each)
    duplicate_steps: int = 0  #: steps whose counter was already summed
    gaps: int = 0  #: step-counter gaps
    missing_steps: int = 0  #: steps lost in those gaps
    #: bytes of a frame the stream ended inside (a capture cut short), dropped by :meth:`HostSession.finish`
    unfinished_bytes: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, int]:
        d = {k: v for k, v in self.__dict__.items() if k != "extra"}
        d.update(self.extra)
        return d


class HostSession:
    """Host protocol state for one link to one module interface; I/O-free.

    *command_set* is ``"2015"`` (current numbering) or ``"2014"``. *ack_policy*
    is ``"auto"``, ``"always"`` or ``"never"``. *tracker* sums the steps (a new
    :class:`StepTracker` at the origin by default; it counts from step 0 as
    after 0x34 — pass ``StepTracker(last_counter=None)`` to attach to a module
    already tracking). *implied_commands* maps wire ids to the (meaning, fields)
    of commands someone else sent (a capture's host), or to a sequence of them: when
    the module acknowledges one this session did not send, it takes effect as if sent
    here — the next of that id's sequence, the last one again once it is used up.
    """

    def __init__(
        self,
        command_set: str | CommandSet = "2015",
        *,
        ack_policy: AckPolicy = "auto",
        tracker: StepTracker | None = None,
        plan: OutputPlan | None = None,
        implied_commands: Mapping[int, tuple[Command, Mapping[str, Any]]
                                  | Sequence[tuple[Command, Mapping[str, Any]]]] | None = None,
    ):
        if ack_policy not in ("auto", "always", "never"):
            raise ValueError(f"ack_policy must be 'auto', 'always' or 'never', not {ack_policy!r}")
        self.command_set: CommandSet = _command_set(command_set)
        self.ack_policy = ack_policy
        self.tracker = tracker if tracker is not None else StepTracker()
        self.plan = plan if plan is not None else OutputPlan()
        self.decoder = StreamDecoder(self.command_set)
        self.stats = SessionStats()
        self.implied_commands = {wire_id: _script(implied)
                                 for wire_id, implied in (implied_commands or {}).items()}
        #: the module's serial number (state 0x04), once a packet carried it
        self.mcu_serial: bytes | None = None
        self._last_number: int | None = None
        self._resend_seen = False

    # -- host → module ------------------------------------------------------------

    def encode_command(self, meaning: Command | str, **fields: Any) -> bytes:
        """The frame of a command in this session's numbering; notes its effect on outputs.

        Raises :class:`NotSupportedByCommandSet` if the numbering lacks it.
        """
        if isinstance(meaning, str):
            meaning = Command[meaning.upper()]
        if not self.command_set.supports(meaning):
            raise NotSupportedByCommandSet(meaning.name, self.command_set.name)
        frame = build_command(meaning, command_set=self.command_set, **fields)
        wire_id = self.command_set.spec(meaning).wire_id
        if self.plan.sent(meaning, wire_id, dict(fields), frame):
            self.tracker.restart_counter(0)
            self._last_number = None
        return frame

    def wire_id(self, meaning: Command) -> int:
        if not self.command_set.supports(meaning):
            raise NotSupportedByCommandSet(meaning.name, self.command_set.name)
        return self.command_set.spec(meaning).wire_id

    @property
    def lossless(self) -> bool:
        """True while the session acknowledges packets."""
        if self.ack_policy == "always":
            return True
        if self.ack_policy == "never":
            return False
        return bool(self.plan.lossless) or self._resend_seen

    # -- module → host ------------------------------------------------------------

    def feed(self, data: bytes) -> tuple[list[StreamEvent], bytes]:
        """Process received bytes: the events they complete, and the acks to send back."""
        data = bytes(data)
        self.stats.bytes_received += len(data)
        return self._frames(self.decoder.feed(data))

    def idle(self) -> tuple[list[StreamEvent], bytes]:
        """The link went quiet: stop waiting on a false frame start if a valid frame follows it."""
        return self._frames(self.decoder.flush())

    def finish(self) -> tuple[list[StreamEvent], bytes]:
        """The stream ended (end of a capture): decode what is complete, drop the rest (counted,
        and the bytes of an unfinished frame at the end in :attr:`SessionStats.unfinished_bytes`)."""
        pending, framed = self.decoder.pending, self.decoder.frame_bytes
        done = self._frames(self.decoder.finish())
        self.stats.unfinished_bytes += pending - (self.decoder.frame_bytes - framed)
        return done

    def link_reset(self) -> None:
        """The link was re-opened: a partial frame from before is gone (counted as garbage).

        The last packet number is kept, so a lossless resend after the reconnect
        is still recognised as a duplicate.
        """
        self.decoder.reset()
        self.stats.garbage_bytes = self.decoder.skipped_bytes

    def _frames(self, frames: list) -> tuple[list[StreamEvent], bytes]:
        events: list[StreamEvent] = []
        out = bytearray()
        for frame in frames:
            if isinstance(frame, CommandAck):
                self.stats.command_acks += 1
                script = self.implied_commands.get(frame.command_id)
                if script and not self.plan.awaiting(frame.command_id):
                    meaning, fields = script[0] if len(script) == 1 else script.popleft()
                    self.encode_command(meaning, **fields)
                self.plan.acked(frame.command_id)
                events.append(CommandAckEvent(frame.command_id))
            elif isinstance(frame, StatePacket):
                self._packet(frame, events, out)
        self.stats.garbage_bytes = self.decoder.skipped_bytes
        self.stats.bad_frames = self.decoder.bad_frames
        return events, bytes(out)

    def _packet(self, pkt: StatePacket, events: list[StreamEvent], out: bytearray) -> None:
        duplicate = pkt.number == self._last_number
        if duplicate and self.ack_policy == "auto":
            self._resend_seen = True  # only a lossless module resends
        states = None
        step = None
        swing_time = math.nan
        if not duplicate:
            layout = self.plan.layout(len(pkt.payload))
            if layout is not None:
                try:
                    states = decode_states(layout, pkt.payload)
                except PayloadError:  # pragma: no cover - layout sizes match by construction
                    states = None
            if states is not None and {StateId.DX, StateId.DP, StateId.STEP_COUNTER} <= states.keys():
                step = Step(
                    dx=states[StateId.DX], dp=states[StateId.DP], counter=int(states[StateId.STEP_COUNTER])
                )
                if StateId.SWING_TIME in states:
                    swing_time = float(states[StateId.SWING_TIME])
            if states is not None and StateId.MCU_ID in states:
                self.mcu_serial = bytes(states[StateId.MCU_ID].astype("u1"))
        if self.lossless or (step is not None and self.ack_policy == "auto"):
            # Step output is lossless by construction (0x34): ack even if we did not see 0x34 sent.
            out += build_packet_ack(pkt.number)
            self.stats.acks_sent += 1
        if duplicate:
            self.stats.duplicate_packets += 1
            return
        if self._last_number is not None and pkt.number != (self._last_number + 1) & 0xFFFF:
            self.stats.packet_number_jumps += 1
        self._last_number = pkt.number
        self.stats.packets += 1
        if states is None:
            self.stats.undecoded_packets += 1
        events.append(PacketEvent(pkt.number, pkt.payload, states))
        if step is not None:
            self._step(step, pkt.number, events, swing_time, states)

    def _step(self, step: Step, number: int, events: list[StreamEvent], swing_time: float,
              states: Mapping[int, Any] | None) -> None:
        n_gaps = len(self.tracker.gaps)
        outcome = self.tracker.add(step, swing_time, states)
        if outcome is StepOutcome.DUPLICATE:
            self.stats.duplicate_steps += 1
            return
        if outcome is StepOutcome.REJECTED:
            self.stats.rejected_steps += 1
        else:
            self.stats.steps += 1
        for gap in self.tracker.gaps[n_gaps:]:
            self.stats.gaps += 1
            self.stats.missing_steps += gap.missing
            events.append(gap)
        track = self.tracker.track
        events.append(
            StepEvent(step, number, outcome, track.final_pose, track.final_covariance, len(track),
                      swing_time)
        )

    def __repr__(self) -> str:
        return (
            f"HostSession({self.command_set.name}, lossless={self.lossless}, packets={self.stats.packets}, "
            f"steps={self.stats.steps}, garbage={self.stats.garbage_bytes})"
        )


def _script(implied) -> deque[tuple[Command, Mapping[str, Any]]]:
    """One implied command, or a sequence of them, as the queue its acks consume."""
    if len(implied) == 2 and isinstance(implied[0], Command):
        return deque([implied])
    return deque(implied)
