"""The µC's state memory: a live typed array behind every state id (protocol.md §4).

Each state of :data:`protocol.states.STATES` is a native-endian numpy array of
its element type and shape (0-d for scalars); processing functions and commands
read and write them in place (``memory[0x19][...] = 100000``). On the wire a
state is its raw memory on a big-endian µC, so :meth:`StateMemory.read_wire`
and :meth:`StateMemory.write_wire` convert to and from big-endian bytes.

Related states share one block so whole ranges can be written at once:
``imu_raw`` (32, 6) int16 behind 0x40..0x5F, ``imu_temp`` (32,) behind
0x60..0x7F, ``imu_mag`` (32, 3) behind 0x90..0xAF and ``ps_dt`` (12,) uint32
behind 0x80..0x8B; ``memory[0x41]`` is a view of ``imu_raw[1]``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from protocol.ids import (
    IMU_MAG_BASE,
    IMU_RAW_BASE,
    IMU_TEMP_BASE,
    MAX_IMU_IDS,
    NR_SLOTS,
    PS_DT_BASE,
    STATE_ID_LIMIT,
    StateId,
)
from protocol.states import STATES, StateSpec

#: Length of the µC serial number (state 0x04).
MCU_ID_LEN = 15
#: Serial number of an emulated module unless configured otherwise.
DEFAULT_MCU_SERIAL = b"OPENSHOE-EMU-01"


class Arena:
    """Typed arrays carved out of one zeroed byte buffer (8-byte aligned), so a compiled
    kernel can take a whole set of them as one argument: ``buf[offsets[key]:…].view(dtype)``.

    *items* are ``(key, dtype, shape)``; ``views[key]`` is the array, ``offsets[key]`` its byte offset.
    """

    def __init__(self, items: list[tuple[object, np.dtype | type, tuple[int, ...]]]):
        offsets: dict[object, int] = {}
        total = 0
        specs = []
        for key, dtype, shape in items:
            dt = np.dtype(dtype)
            nbytes = dt.itemsize * int(np.prod(shape, dtype=np.int64))
            offsets[key] = total
            specs.append((key, dt, shape, total, nbytes))
            total += (nbytes + 7) & ~7
        self.buf = np.zeros(max(total, 8), dtype=np.uint8)
        self.offsets = offsets
        self.views: dict[object, np.ndarray] = {
            key: self.buf[o:o + n].view(dt).reshape(shape) for key, dt, shape, o, n in specs}

    def __repr__(self) -> str:
        return f"Arena({len(self.views)} arrays, {len(self.buf)} B)"


#: The state blocks behind runs of ids: name, first id, how many, element dtype and shape.
_BLOCKS = (("imu_raw", IMU_RAW_BASE, MAX_IMU_IDS, np.int16, (6,)),
           ("imu_temp", IMU_TEMP_BASE, MAX_IMU_IDS, np.int16, ()),
           ("imu_mag", IMU_MAG_BASE, MAX_IMU_IDS, np.int16, (3,)),
           ("ps_dt", PS_DT_BASE, NR_SLOTS, np.uint32, ()))


def _block_of(sid: int) -> tuple[str, int] | None:
    """The block holding state *sid* and its element there, or None for a state of its own."""
    for name, base, n, _dtype, _shape in _BLOCKS:
        if base <= sid < base + n:
            return name, sid - base
    return None


class StateMemory:
    """Live state memory of one module; ``memory[state_id]`` is the array.

    Every state lives in one byte arena (``memory.arena``, byte offset of state *id* in
    ``memory.offsets[id]``, the same layout in every module) so the compiled path
    reaches all of them through one argument.
    """

    def __init__(self, mcu_serial: bytes = DEFAULT_MCU_SERIAL):
        arena = Arena([*((name, dtype, (n, *shape)) for name, _base, n, dtype, shape in _BLOCKS),
                       *((sid, spec.native_dtype, spec.shape) for sid, spec in STATES.items()
                         if _block_of(sid) is None)])
        #: The bytes behind every state (see the class doc).
        self.arena = arena.buf
        self.imu_raw = arena.views["imu_raw"]
        self.imu_temp = arena.views["imu_temp"]
        self.imu_mag = arena.views["imu_mag"]
        self.ps_dt = arena.views["ps_dt"]
        arrays: list[np.ndarray | None] = [None] * STATE_ID_LIMIT
        offsets: dict[int, int] = {}
        for sid, spec in STATES.items():
            where = _block_of(sid)
            if where is None:
                a, off = arena.views[sid], arena.offsets[sid]
            else:
                name, k = where
                block = arena.views[name]
                a = block[k] if block.ndim > 1 else block[k:k + 1].reshape(())
                off = arena.offsets[name] + k * block[:1].nbytes
            assert a.dtype == spec.native_dtype and a.shape == spec.shape, spec
            arrays[sid] = a
            offsets[sid] = off
        self._arrays = arrays
        #: Byte offset of every state in :attr:`arena`.
        self.offsets = offsets
        self._bytes = memoryview(self.arena)  # byte access without numpy scalars (flag())
        self._first_byte: list[int | None] = [offsets.get(i) for i in range(STATE_ID_LIMIT)]
        #: Byte offsets of the blocks imu_raw, imu_temp, imu_mag, ps_dt in :attr:`arena`.
        self.block_offsets = {name: arena.offsets[name] for name, *_ in _BLOCKS}
        self._specs: list[StateSpec | None] = [STATES.get(i) for i in range(STATE_ID_LIMIT)]
        #: Wire size of every id (0 = no state), indexable by any byte value.
        self.sizes: list[int] = [(s.size if s is not None else 0) for s in self._specs] + [0] * (
            256 - STATE_ID_LIMIT
        )
        # every float32 element of the float states, for nonfinite_states()
        floats = [(sid, offsets[sid], spec.size // 4) for sid, spec in STATES.items()
                  if spec.dtype.kind == "f"]
        assert all(spec.dtype.itemsize == 4 for spec in STATES.values() if spec.dtype.kind == "f")
        assert all(off % 4 == 0 for _sid, off, _n in floats), "float states are 4-byte aligned in the arena"
        self._float_words = np.frombuffer(self.arena, dtype=np.float32, count=len(self.arena) // 4)
        self._float_index = np.concatenate([np.arange(off // 4, off // 4 + n) for _sid, off, n in floats])
        self._float_owner = np.concatenate([np.full(n, sid) for sid, _off, n in floats])
        # the words from the first float state's to the last's (other states' words among them),
        # and zeros to weigh them with: their dot product is 0 when every word is finite
        self._float_span = self._float_words[self._float_index[0]:self._float_index[-1] + 1]
        self._float_zeros = np.zeros(len(self._float_span), dtype=np.float32)
        self.set_mcu_serial(mcu_serial)

    # ------------------------------------------------------------------ access
    def __getitem__(self, state_id: int) -> np.ndarray:
        a = self._arrays[state_id] if 0 <= state_id < STATE_ID_LIMIT else None
        if a is None:
            raise KeyError(f"no state with id 0x{state_id:02X}")
        return a

    def __contains__(self, state_id: object) -> bool:
        return isinstance(state_id, int) and 0 <= state_id < STATE_ID_LIMIT and (
            self._arrays[state_id] is not None
        )

    def __iter__(self) -> Iterator[int]:
        return iter(STATES)

    def exists(self, state_id: int) -> bool:
        """Whether *state_id* names a state (ids with no state are ignored by every command)."""
        return 0 <= state_id < STATE_ID_LIMIT and self._arrays[state_id] is not None

    def size(self, state_id: int) -> int:
        """Wire size in bytes of a state, 0 if the id has no state."""
        return self.sizes[state_id] if 0 <= state_id < 256 else 0

    def read_wire(self, state_id: int) -> bytes:
        """The state's bytes as the big-endian µC holds them."""
        spec = self._specs[state_id]
        return self._arrays[state_id].astype(spec.dtype, copy=False).tobytes()

    def write_wire(self, state_id: int, data: bytes) -> None:
        """Overwrite a state with its wire (big-endian) bytes; *data* must be exactly its size."""
        spec = self._specs[state_id] if 0 <= state_id < STATE_ID_LIMIT else None
        if spec is None:
            raise KeyError(f"no state with id 0x{state_id:02X}")
        if len(data) != spec.size:
            raise ValueError(f"state 0x{state_id:02X} ({spec.name}) is {spec.size} bytes, got {len(data)}")
        a = self._arrays[state_id]
        if spec.dtype.itemsize == 1:
            # raw byte copy: a bool state keeps the byte the host wrote, as in C
            a.reshape(-1).view(np.uint8)[:] = np.frombuffer(data, dtype=np.uint8)
        else:
            a[...] = np.frombuffer(data, dtype=spec.dtype).reshape(spec.shape)

    def flag(self, state_id: int) -> bool:
        """A state read as a C bool: true if its first byte is non-zero (false for no state)."""
        off = self._first_byte[state_id] if 0 <= state_id < STATE_ID_LIMIT else None
        if off is None:
            return False
        return self._bytes[off] != 0

    def clear_flag(self, state_id: int) -> None:
        """Write 0 to a state's first byte (``*flag = false``)."""
        a = self._arrays[state_id] if 0 <= state_id < STATE_ID_LIMIT else None
        if a is not None:
            a.reshape(-1).view(np.uint8)[0] = 0

    def nonfinite_states(self) -> tuple[int, ...]:
        """The float states (the navigation numbers: U_K, DT, POSITION, VELOCITY, QUATERNION, P,
        DX, DP, …) that hold an inf or a NaN now, ascending; () when every one is finite. About a
        µs when all are (as after nearly every frame)."""
        if np.vdot(self._float_span, self._float_zeros) == 0:
            # 0 × an inf or a NaN is a NaN, and it stays one through the sum: every word is finite
            # (vdot, unlike dot, does not warn of the invalid products)
            return ()
        # some word is not finite: a float state's, or an integer state's whose bits read so
        values = self._float_words[self._float_index]
        bad = ~np.isfinite(values)
        if not bad.any():
            return ()
        return tuple(sorted({int(sid) for sid in self._float_owner[bad]}))

    # ------------------------------------------------------------- conveniences
    def set_mcu_serial(self, serial: bytes) -> None:
        """Set the 15-byte serial number (state 0x04); shorter values are zero-padded."""
        serial = bytes(serial)
        if len(serial) > MCU_ID_LEN:
            raise ValueError(f"MCU serial number is {MCU_ID_LEN} bytes, got {len(serial)}: {serial.hex(' ')}")
        self[StateId.MCU_ID][:] = np.frombuffer(serial.ljust(MCU_ID_LEN, b"\0"), dtype=np.uint8)

    @property
    def mcu_serial(self) -> bytes:
        return self[StateId.MCU_ID].tobytes()

    def spec(self, state_id: int) -> StateSpec:
        spec = self._specs[state_id] if 0 <= state_id < STATE_ID_LIMIT else None
        if spec is None:
            raise KeyError(f"no state with id 0x{state_id:02X}")
        return spec

    def __repr__(self) -> str:
        return f"StateMemory({len(STATES)} states, MCU serial {self.mcu_serial.hex(' ').upper()})"
