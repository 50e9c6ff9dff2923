"""The emulated firmware traced loop by loop, in the oracle's terms.

:func:`trace_module` runs a module on a sensor source as a host that sent ``STEPWISE_DEAD_RECKONING``
and acknowledges every packet, and records after every loop the detector's statistic T1 and ZUPT flag, the
INS's velocity, and the pose a host holds (the summed steps composed with the INS's pose since the
last reset). :func:`align` shifts it by the filter's delay against the sensors (N/2 samples of the
detector's window, and the accelerometer's one-sample delay), so that index k of the trace and of
the oracle refer to the same recorded sample; :func:`best_lag` checks that delay on the stance flags.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav import config as nav_cfg
from firmware_sim.nav.firmware import build_module
from firmware_sim.nav.profiles import profile_for
from protocol.frames import StatePacket, build_command, build_packet_ack
from protocol.ids import Command, StateId
from protocol.stream import StreamDecoder

__all__ = ["FirmwareTrace", "HostPose", "stepwise_loops", "trace_module", "align", "best_lag",
           "quaternion_yaw", "DESIGN_LAG"]


@dataclass
class FirmwareTrace:
    """Per loop of the module (index = loop number): what the oracle is compared with."""

    zupt: np.ndarray  #: (n,) bool
    t1: np.ndarray  #: (n,) the detector's statistic T1 [LSB_f²] (ZUPT = T1 < TH_ZUPT)
    velocity: np.ndarray  #: (n, 3) [m/s], the INS's
    position: np.ndarray  #: (n, 3) the host's pose: summed steps + the INS's position since the reset
    heading: np.ndarray  #: (n,) [rad], likewise
    reset: np.ndarray | None = None  #: (n,) bool, a step ended (FILTER_RESET_FLAG)
    reset_yaw: np.ndarray | None = None  #: (n,) the yaw each reset took away (DX's heading) [rad]


def quaternion_yaw(q: np.ndarray) -> float:
    """The yaw [rad] of the QUATERNION state (scalar last)."""
    x, y, z, w = (float(c) for c in q)
    return float(np.arctan2(2 * (x * y + z * w), 1 - 2 * (y * y + z * z)))


def stepwise_loops(source, profile: str | None = None, th_zupt: int | None = None,
                   firmware=None) -> Iterator[tuple[int, Module]]:
    """Run a module on *source* as a lossless step-wise host (0x34, every packet acknowledged) and
    yield (loop number, module) after each loop; *profile*, *th_zupt* and *firmware* as in
    :func:`trace_module`."""
    states = {} if th_zupt is None else {StateId.TH_ZUPT: th_zupt}
    config = ModuleConfig(rate_hz=float(source.rate_hz), initial_states=states)
    cfg = profile_for(source, profile).configure(config)
    module = build_module(cfg, sensors=source, firmware=firmware)
    port = module.bt.port
    port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
    decoder = StreamDecoder()
    for k in range(len(source)):
        module.step()
        for frame in decoder.feed(port.host_read()):
            if isinstance(frame, StatePacket):
                port.host_write(build_packet_ack(frame.number))
        yield k, module


class HostPose:
    """The pose a step-wise host holds after each loop of a module: the steps summed so far (each
    reset's DX) composed with the INS's pose since the last reset."""

    def __init__(self) -> None:
        self.base_p, self.base_chi = np.zeros(3), 0.0

    def after_loop(self, mem) -> tuple[np.ndarray, float, float | None]:
        """(position [m], heading [rad], the yaw this loop's reset took away [rad] or None: no reset)
        after the loop that left the module's memory *mem*."""
        reset_yaw = None
        if mem.flag(StateId.FILTER_RESET_FLAG):
            dx = np.asarray(mem[StateId.DX], dtype=np.float64)
            c, s = np.cos(self.base_chi), np.sin(self.base_chi)
            self.base_p = self.base_p + np.array([c * dx[0] - s * dx[1], s * dx[0] + c * dx[1], dx[2]])
            reset_yaw = float(dx[3])
            self.base_chi += reset_yaw
        p = np.asarray(mem[StateId.POSITION], dtype=np.float64)
        c, s = np.cos(self.base_chi), np.sin(self.base_chi)
        position = self.base_p + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])
        return position, self.base_chi + quaternion_yaw(mem[StateId.QUATERNION]), reset_yaw


def trace_module(source, profile: str | None = None, th_zupt: int | None = None,
                 firmware=None) -> FirmwareTrace:
    """Run a module on *source* loop by loop as a lossless step-wise host, and trace it; the module
    navigates with the sensor profile *profile* (default: the source's, as a replay does), boots
    with the ZUPT threshold *th_zupt* (default: its power-on TH_ZUPT) and runs *firmware* (default:
    the OpenShoe firmware; an experiment may swap a processing function)."""
    n = len(source)
    zupt, reset = np.zeros(n, bool), np.zeros(n, bool)
    t1 = np.zeros(n, np.int64)
    reset_yaw = np.zeros(n)
    vel, pos = np.zeros((n, 3)), np.zeros((n, 3))
    heading = np.zeros(n)
    host = HostPose()
    for k, module in stepwise_loops(source, profile, th_zupt, firmware):
        mem = module.memory
        zupt[k] = mem.flag(StateId.ZUPT)
        t1[k] = int(mem[StateId.T1S2F])
        vel[k] = mem[StateId.VELOCITY]
        pos[k], heading[k], yaw = host.after_loop(mem)
        if yaw is not None:
            reset[k], reset_yaw[k] = True, yaw
    return FirmwareTrace(zupt, t1, vel, pos, heading, reset, reset_yaw)


def trace_of_recording(path: str | Path) -> FirmwareTrace:
    """:func:`trace_module` with the defaults on the recording *path* replayed as a replay serves it,
    once per process (the oracle's comparisons trace the same shared walks again). Its arrays are
    read-only (shared by every caller)."""
    return _trace_of(str(Path(path).resolve()))


@functools.cache
def _trace_of(path: str) -> FirmwareTrace:
    from firmware_sim.sensors.replay import ReplaySource, load_recording

    trace = trace_module(ReplaySource(load_recording(path)))
    for f in fields(trace):
        value = getattr(trace, f.name)
        if value is not None:
            value.flags.writeable = False
    return trace


#: Loops the filter runs behind the sensors by design: the middle of the detector's N-sample
#: buffer, and the accelerometer's one-sample delay (firmware.md §3).
DESIGN_LAG = nav_cfg.N // 2 + 1


def best_lag(trace: FirmwareTrace, oracle_stance: np.ndarray, max_lag: int = 64) -> int:
    """The lag (loops) at which the trace's ZUPT flags agree best with *oracle_stance*."""
    n = min(len(trace.zupt), len(oracle_stance))
    return max(range(max_lag + 1), key=lambda lag: int(np.sum(trace.zupt[lag:n] == oracle_stance[:n - lag])))


def align(trace: FirmwareTrace, lag: int = DESIGN_LAG) -> FirmwareTrace:
    """*trace* shifted back by *lag* loops: index k is then the recorded sample k (the last *lag*
    samples are lost)."""
    return FirmwareTrace(trace.zupt[lag:], trace.t1[lag:], trace.velocity[lag:], trace.position[lag:],
                         trace.heading[lag:], None if trace.reset is None else trace.reset[lag:],
                         None if trace.reset_yaw is None else trace.reset_yaw[lag:])
