"""The files a user names on a command line: read, or refused in one line that names the file.

Every loader of a user's file (a capture, a GPS log, a calibration, an emulator's walk or sweep
spec) goes through these, so that what is not a readable file is refused the same way everywhere,
before anything is run, with an :class:`InputFileError` (a :class:`~hostlib.errors.HostError` and a
``ValueError``) saying the file and what is wrong with it:

* no such file, a directory, a file the process may not read, an I/O error: its reason in words;
* a device (``/dev/zero``, a serial port): refused, since reading one as a file never ends (a GPS
  receiver or a module is read live, by its URL); a pipe is read (``<(…)`` in a shell, a named
  pipe), once something writes to it: one nothing writes to within :data:`PIPE_WAIT_S` is refused
  (reading it would wait for ever);
* a file larger than :data:`MAX_INPUT_BYTES` (a day of a module's bytes at the Bluetooth link's
  full rate): refused by its size, before it is read into memory (a walk recording too);
* text that is not UTF-8: the line and the byte;
* JSON that does not parse: the line and column (:func:`load_json`).

The messages read ``FILE: cannot read the WHAT: reason`` and ``FILE: not a WHAT: reason``.

:func:`output_refusal` says, before a run, why an output file could not be written (a directory, a
folder that does not exist, a named pipe nothing reads from), so that a walk is never lost for a
misspelt ``--csv``.
"""

from __future__ import annotations

import errno
import json
import os
import select
import stat
from pathlib import Path
from typing import Any

from .errors import HostError

__all__ = ["MAX_INPUT_BYTES", "PIPE_WAIT_S", "InputFileError", "check_input", "load_json", "output_refusal",
           "read_input", "read_text"]

#: How long a pipe named as an input is waited on for its first byte (or its writer's end) [s].
PIPE_WAIT_S = 10.0
#: The largest input read [B]: a day of a module's bytes at the Bluetooth link's full rate (11 520 B/s)
#: is under 1 GB; an input is read whole into memory.
MAX_INPUT_BYTES = 1_000_000_000


class InputFileError(HostError, ValueError):
    """A file named as an input that cannot be read as one; the message names the file."""


def _reason(exc: OSError) -> str:
    """An OS error in words, without its errno and path: ``No such file or directory``."""
    return exc.strerror or str(exc) or type(exc).__name__


def check_input(path: str | os.PathLike[str], what: str = "file", *, pipes: bool = True) -> Path:
    """*path* as a :class:`~pathlib.Path`, once it is a file that can be opened for reading (a regular
    file or, unless *pipes* is false — for a reader that opens its file more than once —, a pipe);
    :class:`InputFileError` naming it and *what* it was to be otherwise."""
    name = os.fspath(path)
    if not name:
        raise InputFileError(f"an empty name was given for the {what}")
    p = Path(name)
    try:
        st = p.stat()
    except OSError as exc:
        raise InputFileError(f"{name}: cannot read the {what}: {_reason(exc)}") from None
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        raise InputFileError(f"{name}: cannot read the {what}: it is a directory")
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        raise InputFileError(f"{name}: cannot read the {what}: it is a device, not a file")
    if stat.S_ISFIFO(mode) and not pipes:
        raise InputFileError(f"{name}: cannot read the {what}: it is a pipe, and a {what} is read more "
                             "than once: name a file")
    if not (stat.S_ISREG(mode) or stat.S_ISFIFO(mode)):
        raise InputFileError(f"{name}: cannot read the {what}: it is not a file")
    if stat.S_ISREG(mode) and st.st_size > MAX_INPUT_BYTES:  # read whole into memory: refused by its size
        raise InputFileError(_too_big(p, what, f"is {st.st_size / 1e9:.3g} GB"))
    return p


def read_input(path: str | os.PathLike[str], what: str = "file") -> bytes:
    """The bytes of the file *path* (:func:`check_input`; an error while reading refused the same way)."""
    p = check_input(path, what)
    try:
        return _read_pipe(p, what) if stat.S_ISFIFO(p.stat().st_mode) else p.read_bytes()
    except OSError as exc:
        raise InputFileError(f"{os.fspath(path)}: cannot read the {what}: {_reason(exc)}") from None


def _too_big(p: Path, what: str, how: str) -> str:
    return (f"{p}: cannot read the {what}: it {how}, past the {MAX_INPUT_BYTES / 1e9:g} GB an input may "
            "have (a day of a module's bytes at the Bluetooth link's full rate is under 1 GB)")


def _read_pipe(p: Path, what: str) -> bytes:
    """The bytes of the pipe *p* once something writes to it (or its writer ends), within
    :data:`PIPE_WAIT_S`: opened without waiting for a writer, which a plain open would for ever."""
    fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    try:
        ready, _, _ = select.select([fd], [], [], PIPE_WAIT_S)
        if not ready:
            raise InputFileError(f"{p}: cannot read the {what}: a pipe nothing wrote to in {PIPE_WAIT_S:g} s")
        os.set_blocking(fd, True)
        chunks, size = [], 0
        while chunk := os.read(fd, 1 << 16):
            chunks.append(chunk)
            size += len(chunk)
            if size > MAX_INPUT_BYTES:
                raise InputFileError(_too_big(p, what, "goes on"))
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike[str], what: str = "file") -> str:
    """The text of the file *path*, UTF-8 (:func:`read_input`); a byte that is not text is refused
    with its line."""
    data = read_input(path, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise InputFileError(f"{os.fspath(path)}: not a {what}: not text (line {line} has the byte "
                             f"0x{data[exc.start]:02x})") from None


def load_json(path: str | os.PathLike[str], what: str = "file") -> Any:
    """The JSON document in the file *path* (:func:`read_text`); JSON that does not parse is
    refused with its line and column, and so is an empty file."""
    text = read_text(path, what)
    if not text.strip():
        raise InputFileError(f"{os.fspath(path)}: not a {what}: the file is empty")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:  # its text ends "line L column C (char N)"
        raise InputFileError(f"{os.fspath(path)}: not a {what}: invalid JSON ({exc})") from None
    except RecursionError:
        raise InputFileError(f"{os.fspath(path)}: not a {what}: JSON nested too deep") from None


#: Pipes named as outputs, held open for writing from the check on (:func:`output_refusal`).
_HELD_PIPES: list[int] = []


def _pipe_refusal(p: Path, option: str) -> str | None:
    """Why the pipe *p* cannot be written to, or None: one nothing reads from is refused (writing
    would wait for a reader for ever); one that has a reader is held open for writing until this
    process ends, so that the reader sees the output's end only then, not at the check."""
    try:
        fd = os.open(p, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            return f"{option} {p} is a pipe nothing reads from: start its reader first"
        return f"{option} {p}: {_reason(exc)}"
    _HELD_PIPES.append(fd)
    return None


def output_refusal(path: str | os.PathLike[str] | None, option: str) -> str | None:
    """Why the output file *path* of *option* (``--csv``) could not be written, or None (also for
    no *path*): an empty name, a directory, a folder that does not exist or is no folder. Checked
    before a run, so that nothing is walked or computed for a file that cannot be written."""
    if path is None:
        return None
    name = os.fspath(path)
    if not name:
        return f"{option} needs a file name"
    p = Path(name)
    if p.is_dir():
        return f"{option} {name} is a directory: name a file in it"
    if p.is_fifo():
        return _pipe_refusal(p, option)
    parent = p.parent
    if not parent.exists():
        return f"{option} {name}: the folder {parent} does not exist"
    if not parent.is_dir():
        return f"{option} {name}: {parent} is not a folder"
    return None
