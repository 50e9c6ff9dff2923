"""A module as ``serve`` runs it: the module, its links and endpoints, its pacer and READY lines."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from firmware_sim.links.link import Link
from firmware_sim.mcu.module import Module
from firmware_sim.transports.pacer import Pacer


@dataclass
class ServedModule:
    """One running module with its links, endpoints and pacer."""

    index: int
    module: Module
    links: dict[str, Link]
    endpoints: list[Any]
    pacer: Pacer
    ready: list[tuple[str, str]] = field(default_factory=list)
    label: str = ""  #: what tells it apart from the others it runs with: ``m0``, ``left`` (one alone: "")

    def status_line(self) -> str:
        return self.pacer.status().line()
