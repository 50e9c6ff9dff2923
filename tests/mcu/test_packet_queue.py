"""The package queue: lossy and lossless transmission rules of protocol.md §6."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.mcu.packet_queue import QUEUE_BYTES, PackageQueue
from firmware_sim.mcu.port import IdealPort
from protocol.ids import Command, StateId

from .emu import Host, split_frames


class ThrottledPort(IdealPort):
    """An ideal port whose transmit ring takes only *per_tick* bytes per loop."""

    def __init__(self, per_tick: int):
        super().__init__()
        self.per_tick = per_tick
        self._budget = per_tick

    def advance(self, now_cycles: int) -> None:
        super().advance(now_cycles)
        self._budget = self.per_tick

    def tx_free(self) -> int:
        return self._budget

    def tx_write(self, data: bytes) -> None:
        assert len(data) <= self._budget
        self._budget -= len(data)
        super().tx_write(data)


def numbers(frames: list[bytes]) -> list[int]:
    return [int.from_bytes(f[1:3], "big") for f in frames if f[0] == 0xAA]


def lossless_host(rate: int = 1, state_id: int = StateId.GP_ID) -> Host:
    """A host with an output at every 2^(rate-1)-th loop, lossless; its ack already read."""
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=state_id, mode=0x10 | rate)
    first = split_frames(h.step())
    assert first == [bytes.fromhex("A0 20 00 C0")]  # packet 1 waits behind the single-transmit ack
    return h


def test_lossless_sends_only_the_oldest_and_resends_every_128_cycles():
    h = lossless_host()
    out = [split_frames(o) for o in h.per_tick(400)]
    sent_at = [i for i, f in enumerate(out) if f]
    assert all(numbers(out[i]) == [1] for i in sent_at)
    assert sent_at == [0, 128, 256, 384]
    assert h.iface.queue.resends == 3
    assert h.iface.queue.frames[0].number == 1 and len(h.iface.queue) == QUEUE_BYTES // 7


def test_ack_removes_the_oldest_and_the_next_goes_out_at_once():
    h = lossless_host()
    h.step(5)
    h.ack(1)
    assert numbers(split_frames(h.step())) == [2]  # the ACK is received before transmission
    h.ack(2)
    h.ack(3)  # two ACKs in one cycle: each removes the then-oldest
    assert numbers(split_frames(h.step())) == [4]


def test_ack_with_any_other_number_is_ignored():
    h = lossless_host()
    h.step(3)
    q = h.iface.queue
    n = len(q)
    for wrong in (0, 2, 3, 0xFFFF):
        h.ack(wrong)
    assert h.step() == b""
    assert len(q) == n + 1 and q.frames[0].number == 1 and q.acks_ignored == 4


def test_command_ack_waits_behind_unacknowledged_data_in_lossless_mode():
    h = lossless_host(rate=7)  # a packet every 64 loops
    h.step(2)  # packet 1 went out (at the first loop after the ack)
    h.send(bytes.fromhex("03 00 03"))
    assert h.step(50) == b""  # the PING ack is queued behind packet 1
    h.ack(1)
    assert split_frames(h.step()) == [bytes.fromhex("A0 03 00 A3")]
    assert h.step(2) == b""  # sent once, never resent
    frames = split_frames(h.step(30))
    assert numbers(frames) == [2] and len(frames) == 1


def test_command_acks_are_never_resent_and_lossy_sends_everything():
    h = Host()
    h.command(Command.OUTPUT_STATE, state_id=StateId.GP_ID, mode=0x01)
    frames = split_frames(h.step(300))
    assert numbers(frames) == list(range(1, 301))
    assert sum(f[0] == 0xA0 for f in frames) == 1


def test_output_all_off_empties_the_queue():
    h = lossless_host()
    h.step(20)
    assert len(h.iface.queue) > 10
    h.send(bytes.fromhex("22 00 22"))
    h.step()
    # the queue was emptied, then the ack queued; it goes out at once (nothing ahead of it)
    assert len(h.iface.queue) == 0
    assert h.iface.queue.cleared >= 20


def test_full_queue_drops_new_packets_and_counts_them():
    h = lossless_host()
    h.step(300)  # 7-byte packets (1-byte GP_ID): 2048 // 7 = 292 fit
    q = h.iface.queue
    assert len(q) == QUEUE_BYTES // 7
    assert q.used == 7 * (QUEUE_BYTES // 7)
    assert q.dropped == 301 - QUEUE_BYTES // 7
    assert h.iface.counters()["queue_full_drops"] == q.dropped
    # numbers are used by the dropped packets too: the host sees the gap after the ACKs
    last = q.frames[-1].number
    assert last == QUEUE_BYTES // 7


def test_full_queue_drops_command_acks_too():
    h = lossless_host(state_id=StateId.STEP_COUNTER)  # 8-byte packets: 256 fill 2048 bytes
    h.step(300)
    assert h.iface.queue.free == 0
    h.send(bytes.fromhex("03 00 03"))
    before = h.iface.queue.dropped
    h.step()
    assert h.iface.queue.dropped == before + 2  # this cycle's packet and the PING ack


def test_lossy_packet_that_does_not_fit_is_dropped_whole():
    port = ThrottledPort(per_tick=0)
    h = Host()
    h.module.usb.port = h.port = port
    h.iface.pull(StateId.P)  # 186-byte packets
    for _ in range(12):
        h.iface.pull(StateId.P)
        h.step()
    q = h.iface.queue
    assert len(q) == QUEUE_BYTES // 186 and q.dropped == 12 - QUEUE_BYTES // 186


def test_lossy_partly_accepted_packet_is_finished_later():
    port = ThrottledPort(per_tick=50)
    h = Host()
    h.module.usb.port = h.port = port
    h.iface.pull(StateId.P)
    h.module.memory[StateId.P][...] = 1.5
    chunks = h.per_tick(5)
    assert [len(c) for c in chunks] == [50, 50, 50, 36, 0]
    pk = b"".join(chunks)
    assert len(pk) == 186 and split_frames(pk)[0] == pk


def test_queue_rules_directly():
    q = PackageQueue()
    port = IdealPort()
    assert q.add(b"\xAA" * 500, 1, single=False)
    assert q.add(b"\xAA" * 500, 2, single=False)
    assert q.add(b"\xAA" * 500, 3, single=False)
    assert q.add(b"\xAA" * 500, 4, single=False)
    assert not q.add(b"\xAA" * 49, 5, single=False) and q.dropped == 1
    assert q.add(b"\xAA" * 48, 5, single=False)
    assert q.free == 0
    assert q.send_lossless(port) == 500
    assert q.send_lossless(port) == 0  # waits for the ACK
    assert not q.ack(2) and q.ack(1)
    assert q.send_lossless(port) == 500
    q.clear()
    assert len(q) == 0 and q.used == 0


@settings(max_examples=200, deadline=None)
@given(ops=st.lists(st.tuples(st.sampled_from(["add", "ack", "lossy", "lossless", "clear"]),
                              st.integers(1, 600), st.integers(0, 40)), max_size=80))
def test_queue_invariants_under_any_operations(ops):
    q = PackageQueue()
    port = ThrottledPort(per_tick=0)
    number = 0
    for op, size, k in ops:
        port.per_tick = 7 * k
        port.advance(0)
        if op == "add":
            number += 1
            q.add(bytes([0xAA]) + bytes(min(size, 512) - 1), number, single=k % 2 == 0)
        elif op == "ack":
            head = q.frames[0].number if q.frames else None
            removed = q.ack(number - k)
            assert removed == (head == number - k)
        elif op == "lossy":
            q.push_lossy(port)
        elif op == "lossless":
            q.send_lossless(port)
        else:
            q.clear()
        assert 0 <= q.used <= q.capacity and len(q) <= q.max_entries
        assert q.used == sum(f.remaining for f in q.frames)
        assert 0 <= q.delay_counter < q.resend_cycles
