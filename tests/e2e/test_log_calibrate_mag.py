"""Recording the in-situ magnetometer calibration for later: ``openshoe-host log --start --fusion
--calibrate-mag`` against an emulated module (``openshoe://``, virtual time) worn through NavShoe's
calibration walk — a wiggle in one place, then walking off. The log asks for the magnetometer stream
after the fusion set-up, fits and saves the calibration for the module when the first long step
ends the wiggle, and stops the stream; its capture holds the stream, so ``openshoe-host replay
--compass --calibrate-mag`` fits the same calibration from it."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("firmware_sim.transports.protocol_openshoe")

from firmware_sim.sensors.imu_array import make_source  # noqa: E402
from hostlib.calibration.magcal import MagCalibration  # noqa: E402
from hostlib.cli import main  # noqa: E402
from protocol.frames import CommandAck, StatePacket  # noqa: E402
from protocol.stream import decode_all  # noqa: E402

SCENARIO = "navshoe-calibration"
MODULE = 4
URL = f"openshoe://?scenario={SCENARIO}&seed=1&module={MODULE}"
#: The module's calibration file, named after its serial number.
CALIBRATION = f"OSEMU-M{MODULE:08d}.json"
#: The stream's packets: the quaternion and three magnetometers.
STREAM_PAYLOAD = 16 + 3 * 6


class CtrlCOnceSaved(io.StringIO):
    """A terminal (the live line is rewritten at every packet) on which the wearer presses Ctrl-C
    once the module's calibration was saved at *saved*."""

    def __init__(self, saved: Path):
        super().__init__()
        self.saved, self.pressed = saved, False

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> int:
        if not self.pressed and self.saved.is_file():
            self.pressed = True
            raise KeyboardInterrupt
        return super().write(text)


def test_a_logged_wiggle_is_saved_for_the_module_and_its_capture_fits_it_again(tmp_path, capsys):
    raw, live, replayed = tmp_path / "cal.bin", tmp_path / "live", tmp_path / "replayed"
    terminal = CtrlCOnceSaved(live / CALIBRATION)
    argv = ["log", URL, "--raw", str(raw), "--start", "--fusion", "--calibrate-mag",
            "--mag-cal-dir", str(live), "--duration", "120"]  # Ctrl-C ends it; the duration bounds a failure
    assert main(argv, terminal) == 0
    assert terminal.pressed, "the calibration was saved before the duration ran out"
    err = capsys.readouterr().err
    assert "wiggle the shoe in one place" in err and "openshoe-host log: magnetometers calibrated from" in err
    assert f"in situ, saved {live / CALIBRATION}" in err

    frames = decode_all(raw.read_bytes())
    acks = [i for i, f in enumerate(frames) if isinstance(f, CommandAck)]
    assert [frames[i].command_id for i in acks] == [0x34, 0x23, 0x04, 0x21, 0x21], \
        "0x34, the fusion set-up, the stream on and off"
    on, off = acks[3], acks[4]
    stream = [f for f in frames[on:off] if isinstance(f, StatePacket) and len(f.payload) == STREAM_PAYLOAD]
    assert len(stream) > 1800, "62.5 Hz through the 30 s wiggle"

    out = io.StringIO()
    argv = ["replay", str(raw), "--compass", "--calibrate-mag", "--mag-cal-dir", str(replayed)]
    assert main(argv, out) == 0
    assert f"(calibrated: in situ, saved {replayed / CALIBRATION})" in out.getvalue()
    assert (replayed / CALIBRATION).read_text() == (live / CALIBRATION).read_text(), \
        "the capture holds every reading the live fit took"
    world = make_source(SCENARIO, seed=1, module=MODULE).magnetic
    assert np.linalg.norm(MagCalibration.load(live / CALIBRATION).hard_iron - world.hard_iron) < 1.0
