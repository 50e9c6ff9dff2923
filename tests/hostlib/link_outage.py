"""A capture as a host receives it through a link outage: what the module's overflowing queue lets
through (the same cut as the lab's two-feet experiment, ``lab.accuracy.two_feet``; the product's
tests do not import the lab)."""

from __future__ import annotations

from hostlib.events import StepEvent
from hostlib.files.replay import implied_commands
from hostlib.fusion.feet import FootTracker
from hostlib.link.session import HostSession
from protocol.frames import StatePacket
from protocol.stream import decode_all


def drop_packets(capture: bytes, start_s: float, end_s: float) -> tuple[bytes, int]:
    """*capture* without the step packets whose step time lies in [start_s, end_s): what a host
    receives when the link is down that long and the module's queue overflows. Returns the bytes
    and the number of packets dropped."""
    # the host's own decoding gives each step's packet number and (through its tracker) its time
    foot = FootTracker("right", last_counter=None)
    session = HostSession(ack_policy="never", tracker=foot, implied_commands=implied_commands("2015"))
    events = session.feed(capture)[0] + session.finish()[0]
    numbers = [e.packet_number for e in events if isinstance(e, StepEvent)]
    cut = {n for n, t in zip(numbers, foot.step_times, strict=True) if start_s <= t < end_s}
    out = bytearray()
    for frame in decode_all(capture):
        if not (isinstance(frame, StatePacket) and frame.number in cut):
            out += frame.to_bytes()
    return bytes(out), len(cut)
