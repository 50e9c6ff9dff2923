"""The navigation functions inside a module: power-on thresholds, settable by the host, alignment."""

from __future__ import annotations

import numpy as np

from firmware_sim.nav import config as cfg
from firmware_sim.nav.firmware import build_module
from protocol.frames import build_command
from protocol.ids import Command, StateId

from .helpers import reference_config


def test_thresholds_have_their_power_on_defaults():
    m = build_module(reference_config(1000.0))
    assert int(m.memory[StateId.TH_ZUPT]) == cfg.TH_ZUPT_DEFAULT == 16000
    assert int(m.memory[StateId.TH_ZARU]) == cfg.TH_ZARU_DEFAULT == 16


def test_still_board_aligns_level_after_256_stationary_samples():
    m = build_module(reference_config(1000.0))  # default sensors: a board lying still and level
    m.usb.port.host_write(bytes.fromhex("330033"))
    n = m.run_until(lambda mod: bool(mod.memory[StateId.INIT_DONE]), max_ticks=2000)
    # N samples fill the buffer before the first ZUPT, then 256 stationary samples
    assert cfg.ALIGNMENT_SAMPLES < n <= cfg.ALIGNMENT_SAMPLES + cfg.N + 2
    m.run(500)
    np.testing.assert_allclose(m.memory[StateId.QUATERNION], [0, 0, 0, 1], atol=1e-6)
    # 1 g = 9.80665 m/s² on the registers vs g = 9.81 in the INS: ZUPTs hold v_z to ~0.5 mm/s
    assert np.abs(m.memory[StateId.VELOCITY]).max() < 1e-3
    assert bool(m.memory[StateId.ZUPT]) and bool(m.memory[StateId.ZARU])
    assert float(m.memory[StateId.DT]) == np.float32(1e-3)


def test_host_set_threshold_switches_detection_off():
    m = build_module(reference_config(1000.0))
    port = m.usb.port
    port.host_write(build_command(Command.SET_STATE_4, state_id=StateId.TH_ZUPT, data=(0).to_bytes(4, "big")))
    port.host_write(bytes.fromhex("330033"))
    m.run(400)
    assert int(m.memory[StateId.TH_ZUPT]) == 0
    assert not bool(m.memory[StateId.ZUPT])  # T1 < 0 is impossible: never stationary
    assert not bool(m.memory[StateId.INIT_DONE])  # so the INS never aligns
    assert int(m.memory[StateId.T1S2F]) < cfg.TH_ZUPT_DEFAULT  # although the board is still
