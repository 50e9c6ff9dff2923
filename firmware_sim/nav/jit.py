"""Compiling the navigation kernels with numba, when numba is there.

numba is optional (the ``fast`` extra). :func:`kernel` compiles a function in nopython mode,
cached on disk, with C's float division (a division by zero gives inf or NaN, as in the
reference, never an exception). Without numba, or with ``OPENSHOE_PURE=1``, it returns the
function itself: every kernel then runs as plain Python, slowly but with the same results —
which is how the kernel tests run in every job.

* :func:`compiled_reference` compiles a reference function as it is written, the helpers it
  calls by name replaced by their kernels (compiled code calls only compiled functions).
* :func:`plain` gives a kernel back as plain Python, with every kernel it calls plain too.
* :data:`objmode` is numba's object-mode block (a no-op context without numba).
* :func:`bytes_at` is the bytes at an address as an array (the lockstep loop reaches each
  module's records so: :func:`firmware_sim.nav.driver.run_group`).

The on-disk cache: numba renews a cached function when its own source file changes, not when
a function it calls — and compiled into itself — changes in another file. The kernels of one
sequence span several files, so every cache entry made here is stamped with the contents of
all of them (:data:`SOURCES`): editing any of them recompiles the kernels.

Loading a kernel from the cache starts only numba's runtime (:func:`load_cached`), not its
whole typing and lowering set-up, which numba's own load refreshes first and which only a
compile needs (a compile still sets it up itself): that set-up is most of a cache load.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import types
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import numpy as np

from firmware_sim.numba_use import load_cached, pure_requested

from .kernel_sources import SOURCES
from .kernel_sources import sources_stamp as _sources_stamp

__all__ = ["COMPILING", "NUMBA_ERROR", "SOURCES", "bytes_at", "compilations", "compiled_reference", "kernel",
           "load", "load_cached", "numba_version", "objmode", "plain", "pure_requested"]

F = TypeVar("F", bound=Callable[..., Any])


try:  # numba is optional (the `fast` extra)
    if pure_requested():
        raise ImportError("OPENSHOE_PURE=1")
    import numba
    from numba.core import caching
    from numba.core.registry import CPUDispatcher

    if numba.config.DISABLE_JIT:
        raise ImportError("NUMBA_DISABLE_JIT=1")
    NUMBA_ERROR = ""
except ImportError as _e:  # pragma: no cover - depends on the environment
    numba = None
    NUMBA_ERROR = str(_e) or "numba is not installed"

#: Whether :func:`kernel` compiles in this process.
COMPILING = numba is not None

def numba_version() -> str | None:
    return None if numba is None else numba.__version__


#: Each kernel's plain-Python function (for :func:`plain`).
_PLAIN: dict[Any, Callable[..., Any]] = {}

if numba is not None:

    class _Stamped:
        def get_source_stamp(self) -> bytes:
            return _sources_stamp()

    class _UserDirLocator(_Stamped, caching.UserProvidedCacheLocator):
        """NUMBA_CACHE_DIR, when set."""

    class _InTreeLocator(_Stamped, caching.InTreeCacheLocator):
        """``__pycache__`` beside the source."""

    class _UserWideLocator(_Stamped, caching.UserWideCacheLocator):
        """The user's cache folder (a read-only installation)."""

    class _StampedCacheImpl(caching.CompileResultCacheImpl):
        _locator_classes = [_UserDirLocator, _InTreeLocator, _UserWideLocator]

    class _StampedCache(caching.FunctionCache):
        _impl_class = _StampedCacheImpl

        def load_overload(self, sig: Any, target_context: Any) -> Any:
            return load_cached(self, sig, target_context)

    class _KernelDispatcher(CPUDispatcher):
        """numba's CPU dispatcher, its on-disk cache stamped with all of :data:`SOURCES`."""

        def enable_caching(self) -> None:
            self._cache = _StampedCache(self.py_func)

    _OPTIONS = {"nopython": True, "nogil": True, "error_model": "numpy"}


def kernel(fn: F, *, nogil: bool = True) -> F:
    """*fn* compiled (nopython, cached, C division; releasing the GIL unless *nogil* is false:
    a kernel with an object-mode block needs it), or *fn* itself without numba."""
    if numba is None:
        return fn
    compiled = _KernelDispatcher(fn, targetoptions={**_OPTIONS, "nogil": nogil})
    compiled.enable_caching()
    _PLAIN[compiled] = fn
    return compiled  # type: ignore[return-value]


def compiled_reference(fn: F, **helpers: Callable[..., Any]) -> F:
    """The reference function *fn* compiled as it is written, the helpers it calls by the names
    in *helpers* going to those kernels. Without numba, *fn* itself."""
    unknown = set(helpers) - set(fn.__code__.co_names)
    if unknown:
        raise NameError(f"{fn.__qualname__} calls no {', '.join(sorted(unknown))}")
    if numba is None:
        return fn
    clone = types.FunctionType(fn.__code__, {**fn.__globals__, **helpers}, fn.__name__, fn.__defaults__,
                               fn.__closure__)
    functools.update_wrapper(clone, fn)
    compiled = kernel(clone)
    _PLAIN[compiled] = fn
    return compiled


_KernelType: type | tuple[()] = _KernelDispatcher if numba is not None else ()


def load(fn: Callable[..., Any], *args: Any) -> None:
    """Make the kernel *fn* ready for arguments of the types of *args* — loaded from the cache,
    or compiled — without calling it (nothing when *fn* is plain Python)."""
    if isinstance(fn, _KernelType):
        fn.compile(tuple(numba.typeof(a) for a in args))  # type: ignore[attr-defined]


def compilations() -> int:
    """How many compiled versions the kernels of this process hold (compiled or loaded from the
    cache, one per argument types a kernel was called with; 0 without numba). A count that grows
    while a module's clock runs is a compile (or a cache load) that a host waited on."""
    return sum(len(k.signatures) for k in _PLAIN)


@functools.cache
def plain(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The kernel *fn* as plain Python, every kernel it calls by name plain too (*fn* itself when
    it is no kernel: e.g. every kernel without numba)."""
    py = _PLAIN.get(fn)
    if py is None:
        return fn
    names = {n: plain(v) for n in py.__code__.co_names if isinstance(v := py.__globals__.get(n), _KernelType)}
    if not names:
        return py
    clone = types.FunctionType(py.__code__, {**py.__globals__, **names}, py.__name__, py.__defaults__,
                               py.__closure__)
    return functools.update_wrapper(clone, py)


@contextlib.contextmanager
def _no_objmode(**_types: str) -> Iterator[None]:
    yield


#: ``with objmode(out="float32[::1]"): out = reference(…)`` runs the reference function from
#: compiled code (numba's object mode); a no-op block without numba.
objmode = numba.objmode if numba is not None else _no_objmode


def _bytes_at(address: int, size: int) -> np.ndarray:
    """The *size* bytes at *address* as a uint8 array (no copy): plain Python's :func:`bytes_at`."""
    return np.ctypeslib.as_array((ctypes.c_uint8 * size).from_address(address))


if numba is not None:
    from numba.core import types as _types
    from numba.extending import intrinsic

    @intrinsic
    def _byte_pointer(typingctx: Any, address: Any) -> Any:
        """An int64 address as a uint8 pointer (compiled code only)."""
        sig = _types.CPointer(_types.uint8)(_types.int64)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    def _compiled_bytes_at(address, size):  # type: ignore[no-untyped-def]
        return numba.carray(_byte_pointer(address), size)

    _compiled_bytes_at.__doc__ = _bytes_at.__doc__
    bytes_at = kernel(_compiled_bytes_at)
    _PLAIN[bytes_at] = _bytes_at
else:  # pragma: no cover - without numba
    bytes_at = _bytes_at
