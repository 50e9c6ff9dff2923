"""What a replayed capture was: refused when it holds nothing to track, warned about when part of it
was lost.

A capture (``openshoe-host log --raw``, ``openshoe-emu replay --wire``) is the module's bytes as the
host received them. Replaying one that is not — an empty file, a walk recording's text, random
bytes — gives a session that decoded no frame, and a track of no step: :func:`check_capture`
refuses it (:class:`CaptureRefused`, one line saying what was found), so no output file is
written for it. A capture that is mostly frames is tracked, and what was lost is said with its
figures: bytes that were no frame (garbage and bad checksums), a frame the capture ends inside (it
was cut), steps left out because their numbers were impossible.
"""

from __future__ import annotations

from ..errors import HostError
from ..link.session import HostSession

__all__ = ["GARBAGE_WARNING_SHARE", "CaptureRefused", "check_capture"]

#: A capture whose bytes are more than this share garbage is tracked with a warning. A host's own
#: capture holds none (it records what its link delivered, frame after frame); one attached to a
#: module mid-frame starts with a few bytes of a frame, far below 1 %.
GARBAGE_WARNING_SHARE = 0.01


class CaptureRefused(HostError, ValueError):
    """A capture that holds nothing a host can track."""


def check_capture(name: str, data: bytes, session: HostSession) -> list[str]:
    """The warnings about capture *name* (its bytes *data*) after its replay through *session*;
    raises :class:`CaptureRefused` when it held no frame, or no step packet."""
    stats, size = session.stats, len(data)
    frames = stats.packets + stats.duplicate_packets + stats.command_acks
    if size == 0:
        raise CaptureRefused(f"{name} is empty: there is nothing to replay")
    if frames == 0:
        raise CaptureRefused(f"{name}: no OpenShoe frame in its {size} bytes ({stats.garbage_bytes} B were "
                             f"not frames, {stats.bad_frames} bad checksums){_hint(data)}")
    if stats.steps == 0 and stats.rejected_steps == 0:
        raise CaptureRefused(f"{name}: {frames} frames but no step packet: nothing to track (a capture to "
                             "replay starts with 0x34, e.g. `openshoe-host log --start`)")
    warnings = []
    if stats.garbage_bytes > GARBAGE_WARNING_SHARE * size:
        warnings.append(f"{name}: {stats.garbage_bytes} of its {size} bytes "
                        f"({100.0 * stats.garbage_bytes / size:.1f} %) were not frames and "
                        f"{stats.bad_frames} frames had a bad checksum; the track is what its {frames} "
                        "good frames gave")
    if stats.unfinished_bytes:
        warnings.append(f"{name} ends inside a frame: its last {stats.unfinished_bytes} bytes are dropped "
                        "(the capture was cut short)")
    rejections = getattr(session.tracker, "rejections", [])
    if rejections:
        counter, why = rejections[0]
        warnings.append(f"{name}: {len(rejections)} steps left out, their numbers impossible "
                        f"(the first, step {counter}: {why})")
    return warnings


#: Bytes of text: printable ASCII, tab, line feed and carriage return.
_TEXT = frozenset(range(0x20, 0x7F)) | {0x09, 0x0A, 0x0D}


def _hint(data: bytes) -> str:
    """What the bytes look like, when they look like something else than a capture."""
    head = data[:4096]
    if head and sum(b in _TEXT for b in head) >= 0.95 * len(head):
        return ("; it is text: a walk recording is replayed by `openshoe-emu replay FILE --wire OUT`, "
                "which writes the capture to replay here")
    return ""
