"""Test helpers: a module on ideal links driven from the host side, in virtual time."""

from __future__ import annotations

from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav.firmware import build_module
from protocol.frames import build_command, build_packet_ack, checksum
from protocol.ids import Command, Interface


def cmd(meaning: Command | int, **fields) -> bytes:
    """A command frame of the current numbering."""
    return build_command(meaning, **fields)


def with_checksum(body: bytes) -> bytes:
    return body + checksum(body).to_bytes(2, "big")


def split_frames(data: bytes) -> list[bytes]:
    """Split module output into frames (A0 acks: 4 bytes; AA packets: by their length byte).

    Only for payloads < 256 bytes (the length byte is modulo 256).
    """
    frames, i = [], 0
    while i < len(data):
        if data[i] == 0xA0:
            frames.append(data[i:i + 4])
            i += 4
        elif data[i] == 0xAA:
            n = data[i + 3] + 6
            frames.append(data[i:i + n])
            i += n
        else:
            raise AssertionError(f"unexpected byte 0x{data[i]:02X} at {i} in {data.hex(' ')}")
    return frames


class Host:
    """A host on one interface of a module (USB by default)."""

    def __init__(self, module: Module | None = None, interface: Interface = Interface.USB, **config):
        self.module = module if module is not None else build_module(ModuleConfig(**config))
        self.iface = self.module.interfaces[interface]
        self.port = self.iface.port

    def send(self, data: bytes) -> None:
        self.port.host_write(data)

    def command(self, meaning: Command | int, **fields) -> None:
        self.send(cmd(meaning, **fields))

    def ack(self, number: int) -> None:
        self.send(build_packet_ack(number))

    def step(self, n: int = 1) -> bytes:
        """Run n loops; the bytes the host received meanwhile."""
        self.module.run(n)
        return self.port.host_read()

    def frames(self, n: int = 1) -> list[bytes]:
        return split_frames(self.step(n))

    def per_tick(self, n: int) -> list[bytes]:
        """Bytes received after each of n loops."""
        return [self.step() for _ in range(n)]
