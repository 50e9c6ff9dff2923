"""Identifiers of the OpenShoe protocol: commands, states, processing functions.

Everything here is a number that appears on the wire or in the module's process
sequence (protocol.md §3, §4, §10; firmware.md §2). Byte layouts live in
:mod:`protocol.commands` and :mod:`protocol.states`; this module only names ids.
"""

from __future__ import annotations

from enum import IntEnum, IntFlag

#: Number of IMUs on the MIMU22BT board (firmware build constant).
NR_IMUS = 4
#: Highest IMU index for which state ids exist in the table (0x40+i for i = 0..31).
MAX_IMU_IDS = 32
#: Number of process-sequence slots.
NR_SLOTS = 12
#: State ids at or above this do not exist.
STATE_ID_LIMIT = 0xB0
#: Command ids at or above this are never commands.
COMMAND_ID_LIMIT = 0x50
#: Processing-function ids at or above this are ignored by RUN_PROC.
PROC_ID_LIMIT = 0x30


class Command(IntEnum):
    """Command ids of the current firmware (2015-01-15 and later), protocol.md §3."""

    ACK = 0x01
    PING = 0x03
    MCU_ID = 0x04
    SETUP_DEBUG_PROC = 0x10
    INPUT_IMU_RD = 0x11
    SET_STATE_1 = 0x12
    SET_STATE_4 = 0x13
    SET_STATE_12 = 0x14
    SET_STATE_24 = 0x15
    SET_STATE_48 = 0x16
    SET_STATE_254 = 0x17
    OUTPUT_STATE = 0x20
    OUTPUT_MULTIPLE_STATES = 0x21
    OUTPUT_ALL_OFF = 0x22
    STATE_IF_SETUP = 0x23
    OUTPUT_IMU_RD = 0x28
    SET_IMU_BANDWIDTH = 0x29
    RUN_PROC = 0x30
    RUN_MULT_PROC = 0x31
    ALL_PROC_OFF = 0x32
    RESET_ZUPT_AIDED_INS = 0x33
    STEPWISE_DEAD_RECKONING = 0x34
    MIMU_FRONTEND = 0x35
    RESET_PROC_SETUP = 0x36
    STORE_AND_EMPTY = 0x37
    RESTORE_PROC_SEQU = 0x38
    NORMAL_IMU = 0x40
    NORMAL_IMU_WITH_BIAS_EST = 0x41
    GP_TEST = 0x42


class Command2014(IntEnum):
    """Command ids of the firmware before 2015-01-15, protocol.md §10.

    The names are those of the current command with the same meaning.
    """

    ACK = 0x01
    PING = 0x03
    MCU_ID = 0x04
    RESET_ZUPT_AIDED_INS = 0x10
    STEPWISE_DEAD_RECKONING = 0x14
    OUTPUT_STATE = 0x20
    OUTPUT_ALL_OFF = 0x21
    ALL_PROC_OFF = 0x27
    OUTPUT_IMU_RD = 0x28


#: Header byte of a command acknowledgement (module → host).
ACK_HEADER = 0xA0
#: Header byte of a state packet (module → host).
PACKET_HEADER = 0xAA


class StateId(IntEnum):
    """Named state ids, protocol.md §4. Per-IMU ranges are functions below."""

    IMU_TS = 0x01
    INTERRUPT_COUNTER = 0x02
    GP_DT = 0x03
    MCU_ID = 0x04
    GP_ID = 0x05
    U_NEW = 0x10
    U_INT_K = 0x11
    T_INT_K = 0x12
    U_K = 0x13
    DT = 0x14
    T1S2F = 0x15
    T2S2F = 0x16
    ZUPT = 0x17
    ZARU = 0x18
    TH_ZUPT = 0x19
    TH_ZARU = 0x1A
    U_INT16_K = 0x1B
    POSITION = 0x20
    VELOCITY = 0x21
    QUATERNION = 0x22
    P = 0x23
    INIT_DONE = 0x24
    DX = 0x30
    DP = 0x31
    STEP_COUNTER = 0x32
    FILTER_RESET_FLAG = 0x33
    # Emulator extensions in the free range (firmware.md §2: new states below 0xB0); a real
    # OpenShoe firmware has none of them.
    SWING_TIME = 0x34
    THETA_INIT = 0x35
    THETA_GROUND = 0x36


IMU_RAW_BASE = 0x40
IMU_TEMP_BASE = 0x60
PS_DT_BASE = 0x80
IMU_MAG_BASE = 0x90


def imu_raw_id(i: int) -> int:
    """State id of IMU *i*'s raw inertial registers (6 × int16)."""
    _check_imu(i)
    return IMU_RAW_BASE + i


def imu_temp_id(i: int) -> int:
    """State id of IMU *i*'s temperature register (int16)."""
    _check_imu(i)
    return IMU_TEMP_BASE + i


def imu_mag_id(i: int) -> int:
    """State id of IMU *i*'s magnetometer registers (3 × int16)."""
    _check_imu(i)
    return IMU_MAG_BASE + i


def ps_dt_id(slot: int) -> int:
    """State id of the cycle count of process-sequence slot *slot*."""
    if not 0 <= slot < NR_SLOTS:
        raise ValueError(f"slot {slot} out of range 0..{NR_SLOTS - 1}")
    return PS_DT_BASE + slot


def _check_imu(i: int) -> None:
    if not 0 <= i < MAX_IMU_IDS:
        raise ValueError(f"IMU index {i} out of range 0..{MAX_IMU_IDS - 1}")


class ProcId(IntEnum):
    """Processing-function ids of the process sequence, firmware.md §2."""

    STORE_AND_EMPTY_PROC_SEQU = 0x01
    RESTORE_PROC_SEQU = 0x02
    EMPTY_PROCESS_SEQUENCE = 0x03
    RESTORE_PROC_SEQU_IF = 0x04
    STATE_OUTPUT_IF = 0x05
    STATE_OUTPUT_ONCE_IF = 0x06
    STATE_OUTPUT_IF_COUNTER = 0x07
    FRONTEND_PREPROC = 0x10
    FRONTEND_STATDET = 0x11
    FRONTEND_BIASEST = 0x12
    READ_INERTIAL = 0x13
    FRONTEND_CONVCOMP = 0x14
    FRONTEND_CONV16 = 0x15
    MECHANIZATION = 0x20
    TIME_UPDATE = 0x21
    ZUPT_UPDATE = 0x22
    FRONTEND_INITIAL_ALIGNMENT = 0x23
    STEPWISE_SYSTEM_RESET = 0x24
    #: Emulator extension (free id below 0x30): the step's height from the ground's slope.
    HEIGHT_COMPENSATION = 0x25


class OutputMode(IntFlag):
    """Bits of the output mode byte, protocol.md §5."""

    RATE_MASK = 0x07
    MAGNETOMETER = 0x08  # OUTPUT_IMU_RD only
    LOSSLESS = 0x10
    PULL = 0x20
    INERTIAL = 0x40  # OUTPUT_IMU_RD only
    TEMPERATURE = 0x80  # OUTPUT_IMU_RD only


def rate_divider(mode: int) -> int:
    """Output divider D of a mode byte: 0 = off, else 2^(d−1) loop cycles."""
    d = mode & OutputMode.RATE_MASK
    return 0 if d == 0 else 1 << (d - 1)


class Interface(IntEnum):
    """External interfaces of the module (SETUP_DEBUG_PROC's interface byte)."""

    USB = 1
    BLUETOOTH = 2
