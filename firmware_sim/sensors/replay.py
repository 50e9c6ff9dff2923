"""Replay of recorded foot-mounted IMU data through the firmware pipeline.

Two file formats are read, both strictly: a malformed row is refused with a
:class:`RecordingFormatError` (a ``ValueError``) that names the file and the
1-based line number; nothing is silently skipped.

**OpenShoe walk format** (``shared/data/openshoe-walks``, MicroStrain 3DM-GX2,
250 Hz): text with CRLF line ends (bare LF is accepted too, and so is the CR CR LF the
recorder writes now and then; a CR anywhere else is refused), optional blank
lines, a title line, one or more blank lines, a ``Header:`` line naming the 16
columns, then one row per sample of 17 whitespace-separated columns::

    id(hex) a_x a_y a_z [g]  w_x w_y w_z [rad/s]  counter  checksum(hex)  nr
    filtered_ts unfiltered_ts predicted_ts [s]  freq [Hz]  m_x m_y m_z [G]

A compiled reader (:mod:`firmware_sim.sensors.openshoe_scan`, with numba) reads a
well-formed walk in a few milliseconds; anything it is not sure of goes through the
exact parser below, which finds the line and the reason, so both refuse the same files
and give the same numbers, bit for bit.

Acceleration and rate must be finite numbers; the magnetometer columns may be
``nan`` (the recorder writes ``+nan`` when it had no magnetometer reading).
The body frame is the sensor's own, z axis **up** (at rest a_z ≈ +1 g). A last
line without a line end is a row cut off when the recording stopped: it is not
a sample; it is kept, unparsed, in :attr:`Recording.partial_tail` (several of
the shared walks end that way). Time ``t`` is the filtered timestamp relative
to the first sample.

**Plain CSV format** (ours): optional ``#`` comment lines (``# rate_hz=<Hz>``
sets the nominal rate; without it the rate is 1/median(Δt)), then the header
``t,ax,ay,az,gx,gy,gz`` or ``t,ax,ay,az,gx,gy,gz,mx,my,mz``, then one row per
sample: ``t`` in s (strictly increasing), specific force in **g**, angular rate
in **rad/s**, magnetic field in **gauss** (``nan`` allowed) — the units of the
OpenShoe recordings, so converting one to CSV loses nothing — all in the
**board frame** of :mod:`firmware_sim.board` (x forward, y right, z down: at
rest and level a = (0, 0, −1) g). :func:`save_csv` writes it with shortest
round-trip float text, so ``load_csv(save_csv(r))`` returns the same numbers.

**Replay** (:class:`ReplaySource`): the recording is fed at its own rate
(``rate_hz``, 250 Hz for the walks), quantised to MPU9150 registers (2048
LSB/g, 16.4 LSB/(°/s), round to nearest, saturate to int16; magnetometer 0.3
µT/LSB, ±4095) as a *replicated board*: the recording is first turned from
its body frame into the board frame (z-up → z-down is 180° about x), and the
same sample is then given to all four chips, each turned into its own raw axes
with ``board.MIMU22BT.mounting`` (v_chip = mounting[i] @ v_board). Why: the
recording comes from one IMU, while the firmware's front end calibrates,
rotates and averages four chips (sum, shift right by 2). Four equal samples
make that average exactly the recorded sample, with no invented inter-chip
differences (the recording's real noise stays the only noise, no lever-arm
terms are made up), and the firmware path runs unchanged — including the
bottom pair's upside-down mounting, which the calibration matrices undo.
The magnetometer (gauss → µT) goes the same way and then into the AK8975's
own axes (``config.mag.axes``); a missing reading holds the previous one. The
DLPF setting is ignored (the recording is already filtered); the temperature
register holds the reference temperature of the configuration.

**Timing.** A recording holds specific force and rate measured at the same instants. The
firmware's READ_INERTIAL delays the accelerometer triple by one sample (to match the MPU9150
gyro's filter delay), and its MECHANIZATION rotates the specific force with the attitude before
this loop's rate is applied: the attitude it uses is half a sample behind the specific force. On
the module's own 1 kHz data that is 0.5 ms; a 250 Hz recording served as recorded makes the
pairing half a sample (2 ms) early, served one sample ahead half a sample late — on an error-free
simulated 100 m walk replayed at 250 Hz, ±0.26 m in height and 0.03–0.15 m in length either way.
So the accelerometer is served **half a sample ahead** (the mean of each sample and the next, the
last kept): after the firmware's delay each rate is paired with the specific force at the middle
of its own interval, and that walk ends within 0.03 m of the truth
(tests/sensors/test_replay_timing.py; docs/accuracy.md).

**Skipped samples.** A recorder that numbers its samples (the OpenShoe format's ``nr``) shows
where it dropped one. Served as written, the firmware would take the samples either side of a gap
as one sample interval apart: ten samples dropped from a 10 m walk cost it 0.19 m of length and
0.15 m of height. So a replay puts each missing sample back, interpolated linearly between its
neighbours (:meth:`Recording.with_missing_filled`), and ``openshoe-emu replay`` says how many it
put back. Ten put back cost that walk under 2 mm. A CSV recording has no sample numbers; its rows
are served one per sample period as they are.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from firmware_sim.board import MIMU22BT, BoardGeometry
from firmware_sim.mcu.imu_bus import RawSample

from . import openshoe_scan
from .chip_registers import chip_registers
from .config import DEFAULT_CONFIG, SensorConfig
from .registers import INT16_MAX, INT16_MIN, accel_counts, gyro_counts, mag_counts, temp_to_lsb

__all__ = [
    "OPENSHOE_HEADER",
    "OPENSHOE_RATE_HZ",
    "OPENSHOE_SENSOR",
    "Z_UP_TO_BOARD",
    "CSV_HEADER",
    "CSV_HEADER_MAG",
    "RecordingFormatError",
    "Recording",
    "load_recording",
    "load_openshoe",
    "load_csv",
    "save_csv",
    "ReplaySource",
]

#: Nominal sample rate of the OpenShoe walk recordings [Hz].
OPENSHOE_RATE_HZ = 250.0
#: The sensor of the OpenShoe walk format (a sensor profile's name): the MicroStrain 3DM-GX2 logger's.
OPENSHOE_SENSOR = "3dm-gx2"
#: Body frame z up (sensor's own) → board frame z down: 180° about x.
Z_UP_TO_BOARD = np.diag([1.0, -1.0, -1.0])
#: The OpenShoe header line, whitespace-normalised.
OPENSHOE_HEADER = (
    "Header: a_x [g]: a_y [g]: a_z [g]: ar_x [rad/s]: ar_y [rad/s]: ar_z [rad/s]: Counter: "
    "Checksum: Nr: Filtered ts[s]: Unfiltered ts[s]: Pred. ts[s]: Freq. [Hz]: m_x [G]: m_y [G]: m_z [G]:"
)
CSV_HEADER = "t,ax,ay,az,gx,gy,gz"
CSV_HEADER_MAG = CSV_HEADER + ",mx,my,mz"
GAUSS_TO_UT = 100.0
#: The accelerometer's and the gyro's register range.
INT16_RANGE = (INT16_MIN, INT16_MAX)

_NUM = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_NUM_OR_NAN = rf"(?:{_NUM}|[+-]?nan)"
_HEX = r"0[xX][0-9a-fA-F]+"
_SEP = r"[ \t]+"
_OPENSHOE_ROW = re.compile(
    r"[ \t]*" + _HEX
    + (_SEP + f"({_NUM})") * 6  # acc [g], gyro [rad/s]
    + _SEP + r"(\d+)" + _SEP + _HEX + _SEP + r"(\d+)"  # counter, checksum, nr
    + _SEP + f"({_NUM})" + _SEP + _NUM + _SEP + _NUM + _SEP + _NUM_OR_NAN  # ts filtered/unfiltered/pred, freq
    + (_SEP + f"({_NUM_OR_NAN})") * 3  # magnetometer [G]
    + r"[ \t]*"
)
_COLUMN_NAMES = (
    "id", "a_x", "a_y", "a_z", "ar_x", "ar_y", "ar_z", "counter", "checksum", "nr",
    "filtered ts", "unfiltered ts", "predicted ts", "freq", "m_x", "m_y", "m_z",
)  # fmt: skip
_COLUMN_PATTERNS = (
    [_HEX] + [_NUM] * 6 + [r"\d+", _HEX, r"\d+"] + [_NUM] * 3 + [_NUM_OR_NAN] * 4
)


class RecordingFormatError(ValueError):
    """A recording file that is not in the format it claims: names the file and the line."""

    def __init__(self, path: str | Path | None, line: int | None, reason: str, text: str | None = None):
        self.path = str(path) if path is not None else "<recording>"
        self.line = line
        self.reason = reason
        self.text = text
        where = self.path if line is None else f"{self.path}, line {line}"
        message = f"{where}: {reason}"
        if text is not None:
            shown = text if len(text) <= 120 else text[:117] + "..."
            message += f": {shown!r}"
        super().__init__(message)


@dataclass(frozen=True, eq=False)
class Recording:
    """One recorded IMU stream, in the recording's own body frame and units.

    ``t`` [s] from the first sample, ``acc_g`` specific force [g], ``gyro``
    angular rate [rad/s], ``mag`` magnetic field [gauss] (NaN where the
    recorder had none), each (n, 3) float64. ``body_to_board`` turns body
    vectors into the board frame (z-up recordings: 180° about x).
    """

    t: np.ndarray
    acc_g: np.ndarray
    gyro: np.ndarray
    mag: np.ndarray
    rate_hz: float
    body_to_board: np.ndarray = field(default_factory=lambda: np.eye(3))
    path: str | None = None
    format: str = "csv"
    #: Sample numbers of the recorder ("Nr" column), when the format has them.
    nr: np.ndarray | None = None
    #: A last line without a line end (a row cut off by the end of the recording), unparsed.
    partial_tail: str | None = None
    #: The sensor that recorded it, as a sensor profile's name (firmware_sim.nav.profiles), when the
    #: format tells; None: unknown (a replay then uses the module's own figures unless told).
    sensor: str | None = None

    def __post_init__(self) -> None:
        n = len(self.t)
        for name in ("acc_g", "gyro", "mag"):
            if getattr(self, name).shape != (n, 3):
                raise ValueError(f"Recording.{name} must be ({n}, 3), got {getattr(self, name).shape}")

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        return (
            f"Recording({self.path or '<memory>'}, format={self.format}, samples={len(self)}, "
            f"rate_hz={self.rate_hz:g}, duration={self.duration_s:.3f} s)"
        )

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if len(self) else 0.0

    @property
    def missing_samples(self) -> int:
        """Samples the recorder numbered but did not write (gaps in ``nr``); 0 without ``nr``."""
        if self.nr is None or len(self.nr) < 2:
            return 0
        return int(np.sum(np.maximum(np.diff(self.nr) - 1, 0)))

    @property
    def longest_gap(self) -> int:
        """The most samples missing in one place (0: none)."""
        if self.missing_samples == 0:
            return 0
        return int(np.max(np.diff(self.nr)) - 1)

    def with_missing_filled(self) -> Recording:
        """This recording with every sample the recorder numbered but did not write put back, its
        time, specific force and rate interpolated linearly between the samples either side, its
        magnetic field unrecorded (NaN): a replay then serves each of the sensor's sample intervals
        once, as the sensor measured them, and its time stays the sensor's. Itself when none is
        missing."""
        if self.missing_samples == 0:
            return self
        nr = np.asarray(self.nr, dtype=np.int64)
        steps = np.maximum(np.diff(nr), 1)  # a repeated or falling number: no gap there
        index = np.concatenate([[0], np.cumsum(steps)])  # each written sample's place in the filled one
        full = np.arange(index[-1] + 1, dtype=np.float64)

        def interpolate(v: np.ndarray) -> np.ndarray:
            return np.column_stack([np.interp(full, index, v[:, k]) for k in range(v.shape[1])])

        mag = np.full((len(full), 3), np.nan)
        mag[index] = self.mag
        return replace(self, t=np.interp(full, index, self.t), acc_g=interpolate(self.acc_g),
                       gyro=interpolate(self.gyro), mag=mag, nr=nr[0] + full.astype(np.int64))

    def board_acc_g(self) -> np.ndarray:
        """Specific force in the board frame [g], (n, 3)."""
        return self.acc_g @ self.body_to_board.T

    def board_gyro(self) -> np.ndarray:
        """Angular rate in the board frame [rad/s], (n, 3)."""
        return self.gyro @ self.body_to_board.T

    def board_mag(self) -> np.ndarray:
        """Magnetic field in the board frame [gauss], (n, 3); NaN where unrecorded."""
        return self.mag @ self.body_to_board.T


# ---------------------------------------------------------------------------------------------
# reading


def _read_lines(path: Path, data: bytes | None = None) -> tuple[list[str], str | None]:
    """The terminated lines of a text file (without their line ends) and an unterminated tail."""
    if data is None:
        data = path.read_bytes()
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise RecordingFormatError(path, line, f"not ASCII text (byte 0x{data[e.start]:02x})") from None
    lines = text.split("\n")
    tail = lines.pop()  # text after the last line end ('' for a properly ended file)
    lines = [ln.rstrip("\r") for ln in lines]  # CRLF, LF, and the recorder's occasional CR CR LF
    for i, ln in enumerate(lines):
        if "\r" in ln:
            raise RecordingFormatError(path, i + 1, "stray carriage return inside a line", ln)
    return lines, (tail if tail.strip() else None)


def _diagnose_openshoe_row(path: Path, lineno: int, line: str) -> RecordingFormatError:
    tokens = line.split()
    if len(tokens) != len(_COLUMN_NAMES):
        return RecordingFormatError(
            path, lineno, f"expected {len(_COLUMN_NAMES)} columns, found {len(tokens)}", line
        )
    for name, pattern, tok in zip(_COLUMN_NAMES, _COLUMN_PATTERNS, tokens, strict=True):
        if not re.fullmatch(pattern, tok):
            kind = "a finite number" if pattern == _NUM else "a hexadecimal number" if pattern == _HEX else (
                "a number or nan" if pattern == _NUM_OR_NAN else "an unsigned integer"
            )
            return RecordingFormatError(path, lineno, f"column {name!r} must be {kind}, got {tok!r}", line)
    return RecordingFormatError(path, lineno, "malformed row", line)


def _openshoe_data_start(path: Path, lines: list[str]) -> int:
    """Index of the first row: after the title, blank line(s) and the header (refuses others)."""
    i = 0
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines) or lines[i].lstrip().startswith("Header:"):
        raise RecordingFormatError(path, i + 1 if i < len(lines) else None, "missing title line")
    i += 1
    if i >= len(lines) or lines[i].strip():
        raise RecordingFormatError(path, i + 1 if i < len(lines) else None,
                                   "expected a blank line after the title")
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines):
        raise RecordingFormatError(path, None, "missing header line")
    header = " ".join(lines[i].split())
    if header != OPENSHOE_HEADER:
        raise RecordingFormatError(path, i + 1, f"unexpected header (expected {OPENSHOE_HEADER!r})", lines[i])
    return i + 1


def _openshoe_recording(path: Path, cols: np.ndarray, tail: str | None) -> Recording:
    """A recording from the kept fields: 6 imu, counter, nr, filtered ts, 3 mag."""
    ts = cols[:, 8]
    return Recording(
        t=ts - ts[0],
        acc_g=cols[:, 0:3].copy(),
        gyro=cols[:, 3:6].copy(),
        mag=cols[:, 9:12].copy(),
        rate_hz=OPENSHOE_RATE_HZ,
        body_to_board=Z_UP_TO_BOARD.copy(),
        path=str(path),
        format="openshoe",
        nr=cols[:, 7].astype(np.int64),
        partial_tail=tail,
        sensor=OPENSHOE_SENSOR,
    )


#: Lines the compiled reader looks through for the header before leaving the file to the exact parser.
_HEAD_LINES = 64


def _load_openshoe_compiled(path: Path, data: bytes) -> Recording | None:
    """The compiled reader (:mod:`.openshoe_scan`); None when the exact parser must decide."""
    if not openshoe_scan.AVAILABLE:
        return None
    head: list[str] = []
    pos = 0
    while len(head) < _HEAD_LINES and (eol := data.find(b"\n", pos)) >= 0:
        raw = data[pos:eol].rstrip(b"\r")
        if not raw.isascii() or b"\r" in raw:
            return None
        head.append(raw.decode("ascii"))
        pos = eol + 1
        if head[-1].lstrip().startswith("Header:"):
            break
    else:
        return None
    try:
        _openshoe_data_start(path, head)
    except RecordingFormatError:
        return None
    end = data.rfind(b"\n") + 1
    tail = data[end:]
    if not tail.isascii():
        return None
    cols = openshoe_scan.scan_rows(data, pos, end)
    if cols is None or not len(cols):
        return None
    text = tail.decode("ascii")
    return _openshoe_recording(path, cols, text if text.strip() else None)


def load_openshoe(path: str | Path) -> Recording:
    """Parse an OpenShoe walk file (see the module docstring); refuses any malformed line.

    The compiled reader (:mod:`.openshoe_scan`) reads a well-formed file; anything it is not
    sure of goes through the exact parser here, which finds the line and the reason.
    """
    path = Path(path)
    data = path.read_bytes()
    fast = _load_openshoe_compiled(path, data)
    if fast is not None:
        return fast
    lines, tail = _read_lines(path, data)
    first = _openshoe_data_start(path, lines)
    groups = []
    match = _OPENSHOE_ROW.fullmatch
    for k in range(first, len(lines)):
        m = match(lines[k])
        if m is None:
            raise _diagnose_openshoe_row(path, k + 1, lines[k])
        groups.append(m.groups())
    if not groups:
        raise RecordingFormatError(path, None, "no samples")
    return _openshoe_recording(path, np.array(groups, dtype=np.float64), tail)


def load_csv(path: str | Path, rate_hz: float | None = None) -> Recording:
    """Parse our plain CSV format (see the module docstring); refuses any malformed line."""
    path = Path(path)
    lines, tail = _read_lines(path)
    if tail is not None:
        lines.append(tail)  # a CSV written by hand may lack the final line end
    i = 0
    meta_rate = None
    while i < len(lines) and lines[i].startswith("#"):
        m = re.fullmatch(r"#\s*rate_hz\s*=\s*(\S+)\s*", lines[i])
        if m:
            try:
                meta_rate = float(m.group(1))
            except ValueError:
                raise RecordingFormatError(path, i + 1, "rate_hz must be a number", lines[i]) from None
            if not (math.isfinite(meta_rate) and meta_rate > 0):
                raise RecordingFormatError(path, i + 1, "rate_hz must be positive", lines[i])
        i += 1
    if i >= len(lines):
        raise RecordingFormatError(path, None, "missing header line")
    header = lines[i].strip().replace(" ", "")
    if header not in (CSV_HEADER, CSV_HEADER_MAG):
        raise RecordingFormatError(
            path, i + 1, f"header must be {CSV_HEADER!r} or {CSV_HEADER_MAG!r}", lines[i]
        )
    ncol = header.count(",") + 1
    num = re.compile(_NUM)
    numnan = re.compile(_NUM_OR_NAN)
    rows: list[list[float]] = []
    prev_t = -math.inf
    for k in range(i + 1, len(lines)):
        line = lines[k]
        if not line.strip() and k == len(lines) - 1:
            break
        fields = [f.strip() for f in line.split(",")]
        if len(fields) != ncol:
            raise RecordingFormatError(path, k + 1, f"expected {ncol} fields, found {len(fields)}", line)
        for j, f in enumerate(fields):
            ok = (numnan if j >= 7 else num).fullmatch(f)
            if not ok:
                name = header.split(",")[j]
                raise RecordingFormatError(path, k + 1, f"field {name!r} must be a number, got {f!r}", line)
        values = [float(f) for f in fields]
        if not values[0] > prev_t:
            raise RecordingFormatError(path, k + 1, "time t must increase strictly", line)
        prev_t = values[0]
        rows.append(values)
    if not rows:
        raise RecordingFormatError(path, None, "no samples")
    a = np.array(rows, dtype=np.float64)
    mag = a[:, 7:10].copy() if ncol == 10 else np.full((len(a), 3), np.nan)
    rate = rate_hz or meta_rate
    if rate is None:
        if len(a) < 2:
            raise RecordingFormatError(path, None, "one sample and no '# rate_hz=' line: rate unknown")
        rate = float(1.0 / np.median(np.diff(a[:, 0])))
    return Recording(
        t=a[:, 0].copy(), acc_g=a[:, 1:4].copy(), gyro=a[:, 4:7].copy(), mag=mag,
        rate_hz=float(rate), path=str(path), format="csv",
    )


def save_csv(recording: Recording, path: str | Path, comments: Iterable[str] = ()) -> Path:
    """Write a recording in our CSV format (board frame, g, rad/s, gauss), losslessly."""
    path = Path(path)
    acc, gyro, mag = recording.board_acc_g(), recording.board_gyro(), recording.board_mag()
    has_mag = not np.all(np.isnan(mag))
    out = [f"# {c}" for c in comments]
    out.append(f"# rate_hz={float(recording.rate_hz)!r}")
    out.append(CSV_HEADER_MAG if has_mag else CSV_HEADER)
    cols = [recording.t[:, None], acc, gyro] + ([mag] if has_mag else [])
    table = np.hstack(cols).tolist()
    out.extend(",".join(map(repr, row)) for row in table)
    path.write_text("\n".join(out) + "\n", encoding="ascii", newline="\n")
    return path


def _sniff_csv(path: Path) -> bool:
    with path.open("rb") as f:
        head = f.read(4096)
    for raw in head.split(b"\n"):
        line = raw.strip()
        if not line or line.startswith(b"#"):
            continue
        return line.replace(b" ", b"").startswith(b"t,")
    return False


def load_recording(path: str | Path) -> Recording:
    """Load a recording, OpenShoe walk or our CSV (told apart by the first non-comment line)."""
    path = Path(path)
    return load_csv(path) if _sniff_csv(path) else load_openshoe(path)


# ---------------------------------------------------------------------------------------------
# replay


class ReplaySource:
    """A recording served as the raw registers of a replicated 4-chip board (module docstring).

    ``read(index)`` returns sample *index* of the recording (a view into
    precomputed arrays) and None past its end. Satisfies
    :class:`firmware_sim.mcu.imu_bus.SensorSource`.
    """

    def __init__(self, recording: Recording, config: SensorConfig = DEFAULT_CONFIG,
                 geometry: BoardGeometry = MIMU22BT):
        self.recording = recording
        #: Samples the recorder skipped (gaps in its sample numbers), served interpolated
        #: (:meth:`Recording.with_missing_filled`), and the longest such gap.
        self.filled_samples, self.longest_gap = recording.missing_samples, recording.longest_gap
        recording = recording.with_missing_filled()
        self.config = config
        self.rate_hz = float(recording.rate_hz)
        #: The sensor profile's name of the recording's sensor (None: unknown).
        self.sensor = recording.sensor
        self.dlpf_cfg = config.dlpf.cfg
        mount = np.asarray(geometry.mounting, dtype=np.float64)  # (chips, 3, 3)
        n, chips = len(recording), mount.shape[0]
        imu = np.empty((n, chips, 6), dtype=np.int16)
        imu[..., :3] = chip_registers(mount, recording.board_acc_g(), partial(accel_counts, config=config),
                                       INT16_RANGE, ahead=True)
        imu[..., 3:] = chip_registers(mount, recording.board_gyro(), partial(gyro_counts, config=config),
                                       INT16_RANGE)
        self.imu = imu
        # magnetometer: gauss → µT; a missing reading holds the previous one (0 before the first)
        held = recording.board_mag() * GAUSS_TO_UT
        valid = ~np.isnan(held).any(axis=1)
        missing = np.flatnonzero(~valid)
        if len(missing):  # each from the last valid reading before it (only valid rows are read)
            last = np.where(valid, np.arange(n), -1)
            np.maximum.accumulate(last, out=last)
            last = last[missing]
            held[missing] = np.where((last >= 0)[:, None], held[np.maximum(last, 0)], 0.0)
        mag_axes = np.asarray(config.mag.axes, dtype=np.float64)
        full_scale = config.mag.full_scale_lsb
        self.mag = chip_registers(np.einsum("ij,kjl->kil", mag_axes, mount), held,
                                   partial(mag_counts, config=config), (-full_scale, full_scale),
                                   mag_axes, mount)
        self.temp = np.full(chips, temp_to_lsb(config.temperature.reference_c, config), dtype=np.int16)

    @classmethod
    def from_file(cls, path: str | Path, config: SensorConfig = DEFAULT_CONFIG,
                  geometry: BoardGeometry = MIMU22BT) -> ReplaySource:
        return cls(load_recording(path), config, geometry)

    def __len__(self) -> int:
        return len(self.imu)

    def __repr__(self) -> str:
        return f"ReplaySource({self.recording!r})"

    def read(self, index: int) -> RawSample | None:
        if index < 0:
            raise IndexError(f"sample index must be ≥ 0, got {index}")
        if index >= len(self.imu):
            return None
        return RawSample(self.imu[index], self.temp, self.mag[index])

    def set_dlpf(self, cfg: int) -> None:
        """Recorded data is already filtered: the setting is kept but has no effect."""
        if not 0 <= cfg <= 6:
            raise ValueError(f"DLPF_CFG must be 0..6, got {cfg}")
        self.dlpf_cfg = cfg
