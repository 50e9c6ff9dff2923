"""Golden byte vectors from protocol.md §2 (checked by hand there) and known-good frames."""

from __future__ import annotations

import numpy as np


def h(text: str) -> bytes:
    """Bytes from protocol.md-style hex ('AA 00 01 …')."""
    return bytes.fromhex(text)


START_STEPWISE = h("34 00 34")
ACK_OF_START = h("A0 34 00 D4")
PACKET_ACK_0102 = h("01 01 02 00 04")
PING = h("03 00 03")
ALL_OUTPUTS_OFF = h("22 00 22")
SET_TH_ZUPT_100000 = h("13 19 00 01 86 A0 01 53")

#: The synthetic step packet of protocol.md §2: dx = [0.5, 0.01, -0.002, 0.0174],
#: dP diagonal 1e-4, 1e-4, 1e-4, 1e-5, step 1, packet number 1.
STEP_PACKET = h(
    "AA 00 01 3A 3F 00 00 00 3C 23 D7 0A BB 03 12 6F 3C 8E 8A 72 38 D1 B7 17"
    "00 00 00 00 00 00 00 00 00 00 00 00 38 D1 B7 17 00 00 00 00 00 00 00 00"
    "38 D1 B7 17 00 00 00 00 37 27 C5 AC 00 01 0C BE"
)
STEP_DX = np.array([0.5, 0.01, -0.002, 0.0174], dtype=np.float32)
STEP_DP = np.diag(np.array([1e-4, 1e-4, 1e-4, 1e-5], dtype=np.float32))

#: The step packet captured from a real module (stand-still step right after start).
REAL_STEP_PACKET = h(
    "AA 00 01 3A 37 E2 67 6E 34 C5 83 52 B9 FE B0 52 39 80 BE 5B 37 1D D7 64"
    "A8 C2 93 F8 AB ED 34 F3 2E 4D 0E A5 37 1D D7 65 AC A8 B1 A0 AF 22 71 18"
    "37 1D 9D 6D 29 54 78 20 36 5E 8D AC 00 01 1B 6D"
)
REAL_STEP_DX = np.array([2.70e-5, 3.68e-7, -4.86e-4, 2.46e-4])

#: Known-good frames beyond the spec's examples: (what, frame bytes). Checksums by hand:
#: the sum of the bytes before them, mod 2^16, MSB first.
KNOWN_GOOD_COMMANDS = [
    # (meaning, fields, numbering, bytes)
    ("STEPWISE_DEAD_RECKONING", {}, "2014", "14 00 14"),
    ("OUTPUT_ALL_OFF", {}, "2014", "21 00 21"),
    ("ALL_PROC_OFF", {}, "2014", "27 00 27"),
    ("RESET_ZUPT_AIDED_INS", {}, "2014", "10 00 10"),
    ("OUTPUT_STATE", {"state_id": 0x30, "mode": 0x20}, "2015", "20 30 20 00 70"),
    ("OUTPUT_IMU_RD", {"imu_selector": 0x0F, "mode": 0x41}, "2015", "28 00 00 00 0F 41 00 78"),
    ("SET_IMU_BANDWIDTH", {"dlpf_cfg": 3}, "2015", "29 03 00 2C"),
    ("RUN_PROC", {"proc_id": 0x13, "slot": 0}, "2015", "30 13 00 00 43"),
    ("ACK", {"packet_number": 0xFFFF}, "2015", "01 FF FF 01 FF"),
    ("NORMAL_IMU", {"mode": 0x11}, "2015", "40 11 00 51"),
    (
        "OUTPUT_MULTIPLE_STATES",
        {"state_ids": [0x20, 0x21, 0x22, 0, 0, 0, 0, 0], "mode": 0x03},
        "2015",
        "21 20 21 22 00 00 00 00 00 03 00 87",
    ),
]
KNOWN_GOOD_MODULE_FRAMES = [
    ("ack of SETUP_DEBUG_PROC", "A0 10 00 B0"),
    ("ack of 2014 processing off", "A0 27 00 C7"),
    ("empty packet number 0xFFFF", "AA FF FF 00 02 A8"),
    ("packet 2 with GP_ID = 7", "AA 00 02 01 07 00 B4"),
]
