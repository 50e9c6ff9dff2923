"""The OpenShoe tracking firmware: the runtime with the navigation functions linked in.

:data:`OPENSHOE` is the image a MIMU22BT runs (firmware.md §2): the runtime's
sequence control (0x01–0x07), READ_INERTIAL, the integer front end
(0x10–0x15), the ZUPT-aided INS (0x20–0x24), the emulator's slope height
compensation (0x25, in no default sequence: docs/protocol-extensions.md), the
front end's power-on thresholds, and the compiled path of the tracking sequences
(:mod:`firmware_sim.nav.fastpath`) and of any other sequence's numeric slots
(:mod:`firmware_sim.nav.any_sequence`). :func:`build_module` is a
:class:`~firmware_sim.mcu.module.Module` running it — what every user of the
emulator means by "a module".
"""

from __future__ import annotations

from firmware_sim.mcu.firmware import Firmware
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.mcu.port import Port
from firmware_sim.mcu.sequence import FunctionTable
from firmware_sim.mcu.sequence_control import RUNTIME_FUNCTIONS

from . import any_sequence, fastpath, frontend, ins
from .inertial import read_inertial

__all__ = ["NAVIGATION_FUNCTIONS", "OPENSHOE", "build_module"]

#: The processing functions the navigation firmware adds to the runtime's own.
NAVIGATION_FUNCTIONS = (
    read_inertial,
    frontend.frontend_preproc, frontend.frontend_statdet, frontend.frontend_biasest,
    frontend.frontend_convcomp, frontend.frontend_conv16,
    ins.frontend_initial_alignment, ins.ins_mechanization, ins.ins_time_update, ins.ins_zupt_update,
    ins.ins_stepwise_system_reset, ins.ins_height_compensation,
)


def _front_end_defaults(module: Module) -> None:
    """Power-on thresholds of the zero-velocity detector (TH_ZUPT, TH_ZARU)."""
    frontend.apply_state_defaults(module.memory)


#: The MIMU22BT's tracking firmware.
OPENSHOE = Firmware(
    functions=FunctionTable.of(*RUNTIME_FUNCTIONS, *NAVIGATION_FUNCTIONS),
    boot_hooks=(_front_end_defaults, any_sequence.install),
    compiled_path=fastpath.COMPILED_PATH,
    name="OpenShoe tracking firmware",
)


def build_module(config: ModuleConfig | None = None, sensors: SensorSource | None = None,
                 usb_port: Port | None = None, bt_port: Port | None = None, *,
                 firmware: Firmware | None = None) -> Module:
    """A module running *firmware* (default :data:`OPENSHOE`, looked up at each call); the
    other arguments as :class:`~firmware_sim.mcu.module.Module`."""
    return Module(config, sensors, usb_port, bt_port, firmware=firmware or OPENSHOE)
