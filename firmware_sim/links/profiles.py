"""The physical parameters of the kinds of link (:class:`LinkProfile`): Bluetooth, USB and an ideal one.

Bluetooth (profile ``"bt"``): 115200 baud 8N1 UART = 11 520 B/s, a 1024-byte
transmit ring and a 512-byte receive ring in the µC (bytes that do not fit the
receive ring are lost and counted, as on the real module: the UART has no flow
control), SPP one-way latency 20 ms plus 0–20 ms jitter. The jitter is redrawn
every 20 ms of traffic (the radio's latency wanders; chunks are never
reordered, a chunk behind a slower one arrives with it). Bytes waiting in the
radio (between the UART and the host) are limited to ``radio_buffer``; during a
stall that buffer fills and the overflow is lost. By default a Bluetooth link
loses data only where the real one does: ring overflow, stalls and disconnects.

USB (profile ``"usb"``): 1 ms latency, 1 MB/s, and flow control: a full receive
ring holds bytes back instead of losing them, so USB is lossless unless faults
are asked for. ``"ideal"``: no rate, no latency, unbounded buffers.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["BLUETOOTH", "IDEAL", "PROFILES", "USB", "LinkProfile"]


@dataclass(frozen=True)
class LinkProfile:
    """The physical parameters of one kind of link.

    ``rate_bps`` is the wire between the µC and the radio / USB engine in bytes
    per second (``None``: unlimited). Ring and buffer sizes are in bytes
    (``None``: unbounded).
    """

    name: str
    rate_bps: int | None
    tx_ring: int | None  #: the µC's transmit ring
    rx_ring: int | None  #: the µC's receive ring
    latency_s: float  #: one-way base latency
    jitter_s: float  #: extra latency, uniform in [0, jitter_s)
    jitter_period_s: float  #: a new jitter value is drawn this often (per direction)
    flow_control: bool  #: True: a full receive ring holds bytes back; False: they are lost
    radio_buffer: int | None  #: bytes in flight from the wire to the host before overflow
    host_rx_buffer: int | None  #: the host's receive buffer (OS serial / socket buffer)
    host_tx_buffer: int | None  #: bytes in flight host → module before host_write refuses more


BLUETOOTH = LinkProfile(
    name="bt", rate_bps=11_520, tx_ring=1024, rx_ring=512, latency_s=0.020, jitter_s=0.020,
    jitter_period_s=0.020, flow_control=False, radio_buffer=1024, host_rx_buffer=1 << 20,
    host_tx_buffer=64 * 1024,
)
USB = LinkProfile(
    name="usb", rate_bps=1_000_000, tx_ring=4096, rx_ring=4096, latency_s=0.001, jitter_s=0.0,
    jitter_period_s=0.001, flow_control=True, radio_buffer=None, host_rx_buffer=None,
    host_tx_buffer=None,
)
IDEAL = LinkProfile(
    name="ideal", rate_bps=None, tx_ring=None, rx_ring=None, latency_s=0.0, jitter_s=0.0,
    jitter_period_s=1.0, flow_control=True, radio_buffer=None, host_rx_buffer=None,
    host_tx_buffer=None,
)
PROFILES: dict[str, LinkProfile] = {"bt": BLUETOOTH, "bluetooth": BLUETOOTH, "usb": USB, "ideal": IDEAL}
