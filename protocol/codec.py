"""The payload codec: which states a packet carries, their bytes, their typed values.

A state packet's payload is the raw big-endian bytes of the states that were
due, **in ascending state-id order** whatever order the host asked for them
(protocol.md §6). The payload does not say which states it holds: the host knows
that from what it requested. So every function here takes the list of ids a
packet carries; :func:`assembly_order` turns any requested list into the order
and set the module really uses (ascending, duplicates once, ids with no state
skipped), and :func:`fitting_ids` applies the 512-byte packet cap (§9): going up
the ids, a state that would push the payload past :data:`MAX_PAYLOAD` is left
out and the next (smaller) ones are still tried.

Decoded values are numpy arrays in the host's native byte order with the shape
of :data:`protocol.states.STATES` (0-d arrays for scalars).

The step-wise dead-reckoning packet (protocol.md §3 "Mode commands") carries
states 0x30 DX (16 bytes), 0x31 DP (40) and 0x32 STEP_COUNTER (2): 58 bytes,
``0x3A`` in the golden example, 4 + 58 + 2 = 64 with the frame. State 0x33
FILTER_RESET_FLAG is the *flag* of that conditional output (it decides when a
packet is sent) and is not in the payload.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .frames import MAX_PAYLOAD, hexdump
from .ids import StateId
from .states import STATES, StateSpec, symmetric_to_upper, upper_to_symmetric

__all__ = [
    "STEP_IDS",
    "STEP_PAYLOAD_LEN",
    "PayloadError",
    "Step",
    "assembly_order",
    "decode_state",
    "decode_states",
    "decode_step",
    "encode_state",
    "encode_states",
    "encode_step",
    "fitting_ids",
    "left_out_ids",
    "payload_len",
]


class PayloadError(ValueError):
    """A payload that does not match the states it is said to carry."""


def assembly_order(ids: Iterable[int]) -> list[int]:
    """The ids as the module assembles them: ascending, each once, ids with no state dropped."""
    return sorted({int(i) for i in ids if int(i) in STATES})


def fitting_ids(ids: Iterable[int], max_payload: int = MAX_PAYLOAD) -> list[int]:
    """The ids that make it into one packet, in payload order.

    In ascending id order each state is added if it still fits in *max_payload*
    bytes (506: 512 minus header and checksum); one that would overflow is left
    out and the following ones are still tried.
    """
    out: list[int] = []
    used = 0
    for sid in assembly_order(ids):
        size = STATES[sid].size
        if used + size <= max_payload:
            out.append(sid)
            used += size
    return out


def left_out_ids(ids: Iterable[int], max_payload: int = MAX_PAYLOAD) -> list[int]:
    """The existing ids that the packet cap leaves out (ascending)."""
    fit = set(fitting_ids(ids, max_payload))
    return [sid for sid in assembly_order(ids) if sid not in fit]


def payload_len(ids: Iterable[int], max_payload: int = MAX_PAYLOAD) -> int:
    """Bytes of the payload that carries *ids* (after ordering and the cap)."""
    return sum(STATES[sid].size for sid in fitting_ids(ids, max_payload))


def _spec(sid: int) -> StateSpec:
    try:
        return STATES[sid]
    except KeyError:
        raise KeyError(f"no state with id 0x{sid:02X}") from None


def encode_state(state_id: int, value: ArrayLike | bytes) -> bytes:
    """The wire bytes (big-endian) of one state's value.

    *value* is anything numpy turns into the state's shape (a scalar for a
    scalar state), or raw ``bytes`` for a byte state such as MCU_ID. Integer
    values that do not fit the state's type raise ``ValueError``.
    """
    spec = _spec(state_id)
    if isinstance(value, (bytes, bytearray, memoryview)) and spec.dtype.itemsize == 1:
        arr = np.frombuffer(bytes(value), dtype=spec.dtype)
    else:
        arr = np.asarray(value)
    if arr.size != int(np.prod(spec.shape, dtype=np.int64)):
        raise ValueError(f"state 0x{state_id:02X} {spec.name} takes shape {spec.shape}, got {arr.shape}")
    cast = arr.astype(spec.dtype).reshape(spec.shape)
    exact = arr.astype(np.float64).reshape(spec.shape)
    if spec.dtype.kind in "iu" and not np.array_equal(cast.astype(np.float64), exact):
        raise ValueError(
            f"value {arr.tolist()} does not fit state 0x{state_id:02X} {spec.name} ({spec.dtype})"
        )
    return cast.tobytes()


def decode_state(state_id: int, data: bytes) -> np.ndarray:
    """One state's value from its wire bytes: native byte order, the state's shape."""
    spec = _spec(state_id)
    if len(data) != spec.size:
        raise PayloadError(
            f"state 0x{state_id:02X} {spec.name} is {spec.size} bytes, got {len(data)}: {hexdump(data)}"
        )
    return np.frombuffer(bytes(data), dtype=spec.dtype).astype(spec.native_dtype).reshape(spec.shape)


def encode_states(ids: Iterable[int], values: Mapping[int, ArrayLike | bytes]) -> bytes:
    """The payload of a packet carrying *ids* (ordered and capped as the module does).

    *values* maps state id → value; it needs a value for every id that makes
    it into the packet (extra entries are ignored).
    """
    parts = []
    for sid in fitting_ids(ids):
        if sid not in values:
            raise KeyError(f"no value given for state 0x{sid:02X} {STATES[sid].name}")
        parts.append(encode_state(sid, values[sid]))
    return b"".join(parts)


def decode_states(ids: Iterable[int], payload: bytes) -> dict[int, np.ndarray]:
    """The typed values of the states a packet carrying *ids* holds, by id (ascending).

    *ids* are the states the host expects (in any order, as requested); the
    payload layout follows :func:`fitting_ids`. A payload of the wrong length
    raises :class:`PayloadError`.
    """
    order = fitting_ids(ids)
    want = sum(STATES[sid].size for sid in order)
    if len(payload) != want:
        names = " ".join(f"0x{sid:02X}" for sid in order)
        raise PayloadError(
            f"payload for states [{names}] must be {want} bytes, got {len(payload)}: {hexdump(payload)}"
        )
    out: dict[int, np.ndarray] = {}
    pos = 0
    for sid in order:
        size = STATES[sid].size
        out[sid] = decode_state(sid, payload[pos : pos + size])
        pos += size
    return out


# --------------------------------------------------------------------------- step


#: States of a step-wise dead-reckoning packet, in payload order: DX, DP, STEP_COUNTER.
STEP_IDS: tuple[int, ...] = (StateId.DX, StateId.DP, StateId.STEP_COUNTER)
#: Payload bytes of a step packet: 16 + 40 + 2.
STEP_PAYLOAD_LEN = sum(STATES[s].size for s in STEP_IDS)


@dataclass(frozen=True, eq=False)
class Step:
    """One step of step-wise dead reckoning as the module reports it.

    *dx* (float32, (4,)) is the displacement dx, dy, dz [m] and heading change
    dψ [rad] since the previous step, in the previous step's frame; *dp*
    (float32, 4×4, symmetric) its covariance; *counter* the module's uint16
    step counter.
    """

    dx: np.ndarray
    dp: np.ndarray
    counter: int

    def __post_init__(self) -> None:
        dx = np.array(self.dx, dtype=np.float32).reshape(4)
        dp = np.array(self.dp, dtype=np.float32)
        if dp.shape == (10,):
            dp = upper_to_symmetric(dp, 4)
        if dp.shape != (4, 4):
            raise ValueError(f"dp must be 4×4 or its 10-number upper triangle, got shape {dp.shape}")
        counter = int(self.counter)
        if not 0 <= counter <= 0xFFFF:
            raise ValueError(f"step counter {counter} out of range 0..0xFFFF")
        dx.flags.writeable = False
        dp.flags.writeable = False
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "dp", dp)
        object.__setattr__(self, "counter", counter)

    @property
    def dp_upper(self) -> np.ndarray:
        """The 10 numbers of DP as on the wire: xx xy xz xψ yy yz yψ zz zψ ψψ."""
        return symmetric_to_upper(self.dp)

    def to_payload(self) -> bytes:
        return encode_step(self)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Step):
            return NotImplemented
        return (
            self.counter == other.counter
            and np.array_equal(self.dx, other.dx, equal_nan=True)
            and np.array_equal(self.dp, other.dp, equal_nan=True)
        )

    def __hash__(self) -> int:
        return hash((self.counter, self.dx.tobytes(), self.dp.tobytes()))

    def __repr__(self) -> str:
        dx = ", ".join(f"{v:.4g}" for v in self.dx)
        diag = ", ".join(f"{v:.3g}" for v in np.diag(self.dp))
        return f"Step(counter={self.counter}, dx=[{dx}], diag(dp)=[{diag}])"


def decode_step(payload: bytes) -> Step:
    """The :class:`Step` in a 58-byte step-packet payload (DX, DP, STEP_COUNTER)."""
    if len(payload) != STEP_PAYLOAD_LEN:
        raise PayloadError(
            f"a step payload is {STEP_PAYLOAD_LEN} bytes (DX, DP, STEP_COUNTER), "
            f"got {len(payload)}: {hexdump(payload)}"
        )
    v = decode_states(STEP_IDS, payload)
    return Step(dx=v[StateId.DX], dp=v[StateId.DP], counter=int(v[StateId.STEP_COUNTER]))


def encode_step(step: Step | ArrayLike, dp: ArrayLike | None = None, counter: int | None = None) -> bytes:
    """The 58-byte payload of a step: ``encode_step(step)`` or ``encode_step(dx, dp, counter)``.

    *dp* may be the 4×4 matrix (its upper triangle is sent) or the 10 numbers.
    """
    if not isinstance(step, Step):
        if dp is None or counter is None:
            raise TypeError("encode_step(dx, dp, counter) needs dp and counter, or pass a Step")
        step = Step(dx=np.asarray(step), dp=np.asarray(dp), counter=counter)
    return encode_states(
        STEP_IDS,
        {StateId.DX: step.dx, StateId.DP: step.dp_upper, StateId.STEP_COUNTER: step.counter},
    )
