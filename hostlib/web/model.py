"""What a live page shows, held in bounded memory: :class:`LiveModel`, named series of points and a
set of values, and the messages that keep a page in step with it.

A *series* is a list of points (each a short list of numbers) that only grows at its end — a track,
the GPS fixes. It holds at most its *cap* points: when an append takes it past the cap, its older
points are thinned (:func:`thin`: every other one dropped, the newest quarter and the first point
kept), so a long walk keeps the whole walk's shape at a coarser grain and the memory stays bounded
however long it goes. *Values* are a flat dict of anything JSON can hold (counters, the state of
each link), replaced key by key.

A page subscribes (:meth:`LiveModel.subscribe`) and is given, atomically, the whole model as a
``reset`` message; then every change as one message, JSON text made once for all pages:

* ``{"seq": n, "reset": true, "series": {name: points}, "values": {...}}`` — the whole model;
* ``{"seq": n, "append": {name: points}, "series": {name: points}, "values": {...},
  "transient": {...}}`` — points added at a series' end; series replaced whole (thinned, or their
  past changed: a filter turned the whole track); values changed; and what happened in this
  update only, never kept (e.g. when the steps it carries arrived).

A page that applies these messages holds exactly what the model holds: never more than the caps.

Each point is kept as its JSON text, made once when it comes (about 60 bytes for a track's point
against 300 as a list of Python numbers): a message or a reset splices the texts in, and
:meth:`LiveModel.points` reads them back in one parse.
"""

from __future__ import annotations

import json
import math
import threading
from collections.abc import Callable, Iterable, Mapping
from typing import Any

__all__ = ["LiveModel", "Listener", "clean", "thin"]

#: Who hears of a model's messages: called with each message's JSON text, under the model's lock
#: (it must only hand the text on, e.g. to an event loop).
Listener = Callable[[str], object]


def thin(points: list, cap: int) -> list:
    """*points* cut to at most *cap*: while too many, every other point of the older three quarters is
    dropped (the first point and the newest quarter kept whole)."""
    if cap < 4:
        raise ValueError(f"a series holds at least 4 points, not {cap}")
    while len(points) > cap:
        newest = cap // 4
        older, recent = points[:-newest], points[-newest:]
        points = older[::2] + recent
    return points


def clean(value: Any, digits: int = 3) -> Any:
    """*value* as JSON holds it: floats rounded to *digits* decimals, NaN and infinities as None,
    numpy numbers and arrays as plain ones, tuples as lists (recursively)."""
    kind = type(value)
    if kind is float:
        return round(value, digits) if math.isfinite(value) else None
    if kind is int or kind is str or kind is bool or value is None:
        return value
    if kind is list or kind is tuple:
        return [clean(v, digits) for v in value]
    if isinstance(value, Mapping):
        return {str(k): clean(v, digits) for k, v in value.items()}
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return clean(value.tolist(), digits)
    if isinstance(value, float):
        return clean(float(value), digits)
    if isinstance(value, int):
        return int(value)
    return str(value)


class LiveModel:
    """Named series, each holding at most its cap of points, and values (module docstring).

    *kind* names the page (``"walk"``, ``"emulator"``); *caps* gives each series its cap, and a series
    not named there gets *default_cap*. Thread-safe: one thread updates, any thread subscribes.
    """

    def __init__(self, kind: str, caps: Mapping[str, int] | None = None, default_cap: int = 1000):
        self.kind = kind
        self.caps = dict(caps or {})
        self.default_cap = default_cap
        self._series: dict[str, list] = {}
        self._values: dict[str, Any] = {"kind": kind}
        self._listeners: list[Listener] = []
        self._lock = threading.Lock()
        self.seq = 0  #: messages made so far

    def cap(self, name: str) -> int:
        """How many points series *name* holds at most."""
        return self.caps.get(name, self.default_cap)

    def points(self, name: str) -> list:
        """A copy of series *name*'s points (empty if it has none), as :func:`clean` made them."""
        with self._lock:
            texts = self._series.get(name, ())
            return json.loads("[" + ",".join(texts) + "]")

    def value(self, name: str, default: Any = None) -> Any:
        with self._lock:
            return self._values.get(name, default)

    def sizes(self) -> dict[str, int]:
        """How many points each series holds now."""
        with self._lock:
            return {name: len(points) for name, points in self._series.items()}

    def update(self, *, append: Mapping[str, Iterable] | None = None,
               replace: Mapping[str, Iterable] | None = None, values: Mapping[str, Any] | None = None,
               transient: Mapping[str, Any] | None = None) -> None:
        """Replace whole series (*replace*), then add points at the ends of others (*append*), set
        *values*, and tell every subscriber in one message (with *transient*, which is not kept).
        Nothing changed and nothing transient: no message."""
        with self._lock:
            replaced: dict[str, list[str]] = {}
            appended: dict[str, list[str]] = {}
            for name, pts in (replace or {}).items():
                replaced[name] = self._series[name] = thin(_texts(pts), self.cap(name))
            for name, pts in (append or {}).items():
                new = _texts(pts)
                if not new:
                    continue
                old = self._series.setdefault(name, [])
                if name in replaced or len(old) + len(new) > self.cap(name):
                    replaced[name] = self._series[name] = thin(old + new, self.cap(name))
                else:
                    old.extend(new)
                    appended[name] = new
            changed = {k: v for k, v in clean(dict(values or {})).items()
                       if k not in self._values or self._values[k] != v}
            self._values.update(changed)
            if not (replaced or appended or changed or transient):
                return
            self.seq += 1
            parts = [f'{{"seq":{self.seq}']
            if appended:
                parts.append(f',"append":{_series_json(appended)}')
            if replaced:
                parts.append(f',"series":{_series_json(replaced)}')
            if changed:
                parts.append(f',"values":{_json(changed)}')
            if transient:
                parts.append(f',"transient":{_json(clean(dict(transient), 6))}')
            text = "".join(parts) + "}"
            for listener in list(self._listeners):
                listener(text)

    def snapshot(self) -> str:
        """The whole model as a ``reset`` message (JSON text)."""
        with self._lock:
            return self._snapshot()

    def _snapshot(self) -> str:
        return (f'{{"seq":{self.seq},"reset":true,"series":{_series_json(self._series)},'
                f'"values":{_json(self._values)}}}')

    def subscribe(self, listener: Listener) -> str:
        """Tell *listener* every message from now on; returns the whole model as it is now, so that the
        two fit with nothing lost or told twice."""
        with self._lock:
            self._listeners.append(listener)
            return self._snapshot()

    def unsubscribe(self, listener: Listener) -> None:
        """Stop telling *listener* (one not subscribed: nothing)."""
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    @property
    def subscribers(self) -> int:
        with self._lock:
            return len(self._listeners)


def _json(value: Any) -> str:
    """*value* (already :func:`clean`) as compact JSON text."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False)


def _texts(points: Iterable) -> list[str]:
    """Each of *points*, cleaned, as its JSON text."""
    return [_json(p) for p in clean(list(points))]


def _series_json(series: Mapping[str, list[str]]) -> str:
    """Series of point texts as one JSON object: name → the list of its points."""
    return "{" + ",".join(f'{json.dumps(name)}:[{",".join(texts)}]' for name, texts in series.items()) + "}"
