"""What a pacer pumps: host-facing endpoints, and the link models behind them."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, Protocol

from firmware_sim.mcu.module import Module


class Endpoint(Protocol):
    """A host-facing transport the pacer pumps."""

    def pump(self) -> None: ...

    def close(self) -> None: ...


def port_behind(endpoint: Endpoint) -> Any:
    """The module's port an endpoint reaches (through a hub's tap: the hub's shared port)."""
    port = getattr(endpoint, "port", None)
    hub = getattr(port, "hub", None)
    return hub.port if hub is not None else port


def links_of(endpoints: Iterable[Endpoint]) -> list[Any]:
    """The link models behind *endpoints* (ports with a host clock; a hub's link once)."""
    out: list[Any] = []
    for port in map(port_behind, endpoints):
        if hasattr(port, "host_clock") and all(port is not o for o in out):
            out.append(port)
    return out


def lookahead_cycles(module: Module, endpoints: list[Endpoint]) -> int:
    """Cycles a module may run ahead of its hosts: the least one-way latency of the ports
    behind its endpoints, less one tick (0 for a port without latency, or with no host).
    An endpoint that carries nothing to the module (``to_module = False``: the simulated GPS
    receiver's pty) does not count."""
    ports = [port_behind(ep) for ep in endpoints if getattr(ep, "to_module", True)]
    least = min((port.lookahead_cycles() if callable(getattr(port, "lookahead_cycles", None)) else 0
                 for port in ports), default=0)
    return max(0, least - module.clock.cycles_per_tick)
