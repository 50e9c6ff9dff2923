"""The recipe language of :mod:`.scenarios`, read and checked piece by piece.

A recipe is pieces joined by ``+``, each ``name[:number[:number…]]`` (the pieces and what their
numbers mean: :mod:`.scenarios`). :func:`parse` reads one into pieces (:class:`Piece`), :func:`walk`
has a :class:`~.gait_builder.GaitBuilder` walk them; whatever is refused raises :class:`RecipeError`,
whose message names the piece (its place in the recipe and its text), the number at fault and
the range it must lie in::

    piece 2 'walk:-5': the length m [m] must be > 0 and at most 2500, got -5

Every number must be finite and inside its piece's range; counts (stairs, steps, laps) must be
whole numbers. The ranges follow what a walker does, and what a simulated walk can hold:

* :data:`MAX_DURATION_S` bounds the whole scenario, its stands included. A simulated source
  samples the walk's ground truth at every loop when it is made (about 1.5 kB a sample at
  1 kHz, with the sensors' registers): half an hour is some 2.7 GB. It also bounds how long a
  piece's building takes: the check runs after each piece, so nothing runs for ever.
* :data:`MAX_LENGTH_M` bounds a piece's distance: half an hour's walk at the default pace
  (1.5 m a stride, one a second) is 2.7 km; a 400 m track: 6 laps. An arc's length r · deg and a
  rectangle's perimeter count as well.
* :data:`MAX_SLOPE_DEG`: the steepest streets are under 20°; steeper ground is climbed, not
  walked (stairs are pieces of their own).
* turns (``turn``, ``arc``) up to ten whole turns, a heading (``face``) within one turn;
  ``pace`` from a slow stroll (0.3 m/s) to a race walker's 3 m/s; a ``wiggle`` of at most
  ten minutes, tilting the foot by at most 90°; up to 2000 stairs in a piece (the tallest
  towers' stair races are about that) and 1000 side or back steps.
* :data:`MAX_PIECES` pieces in a recipe (the longest named scenario has under a hundred).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from .gait import RUNNING, WALKING, GaitParams
from .gait_builder import GaitBuilder

__all__ = ["MAX_DURATION_S", "MAX_LENGTH_M", "MAX_PIECES", "MAX_SLOPE_DEG", "MAX_TURN_DEG", "PIECE_SPECS",
           "Arg", "Piece", "PieceSpec", "RecipeError", "parse", "parse_piece", "walk"]

#: The longest scenario, stands included [s] (module docstring).
MAX_DURATION_S = 1800.0
#: The longest distance one piece covers [m].
MAX_LENGTH_M = 2500.0
#: The steepest slope a walk or ramp may have [deg].
MAX_SLOPE_DEG = 30.0
#: The most pieces a recipe may have.
MAX_PIECES = 1000
#: The most a turn, or an arc, may turn [deg]: ten whole turns.
MAX_TURN_DEG = 3600.0


class RecipeError(KeyError, ValueError):
    """A scenario that is neither a known name nor a recipe that can be walked.

    A ValueError (a bad value), and a KeyError for callers that look a scenario's name up;
    ``str()`` is its message alone, naming the piece and what is wrong with it."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass(frozen=True)
class Arg:
    """One number of a piece: *name* (as the scenarios' table writes it), its *default*, and the
    range *lo* … *hi* it must lie in (*lo* itself excluded when *above*; whole numbers only when
    *whole*); *what* says it in words with its unit."""

    name: str
    default: float
    lo: float
    hi: float
    what: str
    above: bool = False
    whole: bool = False

    def range_text(self) -> str:
        if self.whole:
            return f"a whole number from {self.lo:g} to {self.hi:g}"
        if self.above:
            return f"> {self.lo:g} and at most {self.hi:g}"
        return f"from {self.lo:g} to {self.hi:g}"

    def refusal(self, value: float) -> str | None:
        """Why *value* is refused, or None."""
        low = value > self.lo if self.above else value >= self.lo
        ok = math.isfinite(value) and low and value <= self.hi
        if ok and (not self.whole or value == int(value)):
            return None
        return f"{self.what} must be {self.range_text()}, got {value:g}"


def _whole(value: float) -> int:
    return int(value)


@dataclass(frozen=True)
class PieceSpec:
    """A piece of the language: its numbers, how a builder walks it (``walk(builder, *numbers)``)
    and, for pieces whose numbers bound one another, *check* (why the numbers are refused, or None)."""

    name: str
    args: tuple[Arg, ...]
    walk: Callable[..., object]
    check: Callable[..., str | None] | None = None

    @property
    def usage(self) -> str:
        """``walk[:m[:deg]]``."""
        return self.name + "".join(f"[:{a.name}" for a in self.args) + "]" * len(self.args)


@dataclass(frozen=True)
class Piece:
    """A piece of a recipe as written (*text*, at *place* 1, 2, …; 0 for one added by the
    scenarios), its spec and its numbers (defaults filled in)."""

    place: int
    text: str
    spec: PieceSpec
    values: tuple[float, ...]

    @property
    def name(self) -> str:
        return self.spec.name

    def label(self) -> str:
        return f"piece {self.place} {self.text!r}" if self.place else f"the added piece {self.text!r}"


# --------------------------------------------------------------------------- the pieces


def _length(default: float) -> Arg:
    return Arg("m", default, 0.0, MAX_LENGTH_M, "the length m [m]", above=True)


def _slope(default: float = 0.0) -> Arg:
    return Arg("deg", default, -MAX_SLOPE_DEG, MAX_SLOPE_DEG, "the slope deg [deg]")


def _count(name: str, default: float, most: float, what: str) -> Arg:
    return Arg(name, default, 1, most, what, whole=True)


def _pace(b: GaitBuilder, v: float) -> None:
    b.params = WALKING.with_speed(v)


def _arc_refusal(r: float, deg: float) -> str | None:
    length = r * abs(deg) * math.pi / 180.0
    if length > MAX_LENGTH_M:
        return f"the arc is {length:.0f} m long (r · deg): at most {MAX_LENGTH_M:g}"
    return None


def _rectangle_refusal(length: float, width: float, r: float) -> str | None:
    if 2 * r > min(length, width):
        half = min(length, width) / 2
        return f"the corner radius r must be at most half the shorter side ({half:g}), got {r:g}"
    if 2 * (length + width) > MAX_LENGTH_M:
        return f"the perimeter 2 (l + w) is {2 * (length + width):g} m: at most {MAX_LENGTH_M:g}"
    return None


def _side_refusal(n: float, direction: float) -> str | None:
    if direction in (-1.0, 1.0):
        return None
    return f"the direction dir must be 1 (right) or -1 (left), got {direction:g}"


_TURN = Arg("deg", 90.0, -MAX_TURN_DEG, MAX_TURN_DEG, "the turn deg [deg, right > 0]")
_STAIRS = _count("n", 12, 2000, "the number of stairs n")

#: name → the piece (:mod:`.scenarios`' table says what each does).
PIECE_SPECS: dict[str, PieceSpec] = {s.name: s for s in (
    PieceSpec("stand", (Arg("s", 3.0, 0.0, MAX_DURATION_S, "the time s [s]", above=True),),
              lambda b, s: b.stand(s)),
    PieceSpec("walk", (_length(10.0), _slope()), lambda b, m, deg: b.walk(m, slope_deg=deg)),
    PieceSpec("ramp", (_length(50.0), _slope(6.0),
                       Arg("across", 0.0, -360.0, 360.0, "the uphill direction across [deg]")),
              lambda b, m, deg, across: b.ramp(m, deg, across)),
    PieceSpec("run", (_length(50.0),), lambda b, m: b.run(m, RUNNING)),
    PieceSpec("arc", (Arg("r", 2.0, 0.0, MAX_LENGTH_M, "the radius r [m]", above=True), _TURN),
              lambda b, r, deg: b.arc(r, deg), _arc_refusal),
    PieceSpec("turn", (_TURN,), lambda b, deg: b.turn_on_spot(deg)),
    PieceSpec("stairs_up", (_STAIRS,), lambda b, n: b.stairs(_whole(n), up=True)),
    PieceSpec("stairs_down", (_STAIRS,), lambda b, n: b.stairs(_whole(n), up=False)),
    PieceSpec("side", (_count("n", 4, 1000, "the number of steps n"),
                       Arg("dir", 1.0, -1.0, 1.0, "the direction dir", whole=True)),
              lambda b, n, d: b.side_steps(_whole(n), right=d > 0), _side_refusal),
    PieceSpec("back", (_count("n", 4, 1000, "the number of steps n"),), lambda b, n: b.back_steps(_whole(n))),
    PieceSpec("rectangle", (Arg("l", 30.0, 0.0, MAX_LENGTH_M / 2, "the length l [m]", above=True),
                            Arg("w", 15.0, 0.0, MAX_LENGTH_M / 2, "the width w [m]", above=True),
                            Arg("r", 1.0, 0.0, 100.0, "the corner radius r [m]", above=True)),
              lambda b, length, w, r: b.rectangle(length, w, r), _rectangle_refusal),
    PieceSpec("track400", (_count("laps", 1, MAX_LENGTH_M // 400, "the number of laps"),),
              lambda b, laps: b.track_400m(laps=_whole(laps))),
    PieceSpec("pace", (Arg("v", 1.55, 0.3, 3.0, "the walking speed v [m/s]"),), _pace),
    PieceSpec("face", (Arg("deg", 0.0, -360.0, 360.0, "the heading deg [deg east of north]"),),
              lambda b, deg: b.face(deg)),
    PieceSpec("wiggle", (Arg("s", 30.0, 0.0, 600.0, "the time s [s]", above=True),
                         Arg("deg", 90.0, 0.0, 90.0, "the tilt deg [deg]")),
              lambda b, s, deg: b.wiggle(s, deg)),
)}


# --------------------------------------------------------------------------- reading and walking


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def parse_piece(text: str, place: int) -> Piece:
    """One piece *text* (at *place* in its recipe); :class:`RecipeError` naming it otherwise."""
    name, *words = (word.strip() for word in text.split(":"))
    label = f"piece {place} {text!r}" if place else f"the piece {text!r}"
    spec = PIECE_SPECS.get(name)
    if spec is None:
        raise RecipeError(f"{label}: unknown piece {name!r}; known: {', '.join(sorted(PIECE_SPECS))}")
    if len(words) > len(spec.args):
        raise RecipeError(f"{label}: {name} takes at most {len(spec.args)} number"
                          f"{'s' if len(spec.args) != 1 else ''} ({spec.usage}), got {len(words)}")
    values = []
    for i, arg in enumerate(spec.args):
        value = arg.default if i >= len(words) else _number(words[i])
        if value is None:
            raise RecipeError(f"{label}: arguments must be numbers: {arg.name} is {words[i]!r} "
                              f"({spec.usage})")
        refusal = arg.refusal(value)
        if refusal is not None:
            raise RecipeError(f"{label}: {refusal}")
        values.append(value)
    refusal = spec.check(*values) if spec.check is not None else None
    if refusal is not None:
        raise RecipeError(f"{label}: {refusal}")
    return Piece(place, text, spec, tuple(values))


def parse(text: str) -> list[Piece]:
    """The pieces of the recipe *text* (empty pieces, ``a++b``, are skipped); :class:`RecipeError`
    for the first that is refused, or for more than :data:`MAX_PIECES`."""
    words = [(place, word.strip()) for place, word in enumerate(text.split("+"), 1)]
    words = [(place, word) for place, word in words if word]
    if len(words) > MAX_PIECES:
        raise RecipeError(f"a recipe has at most {MAX_PIECES} pieces, this one {len(words)}")
    pieces = [parse_piece(word, place) for place, word in words]
    for piece in pieces[1:]:
        if piece.name == "face":
            raise RecipeError(f"{piece.label()}: face sets the heading the walk starts with: it can only be "
                              "the first piece")
    return pieces


def walk(pieces: Sequence[Piece], params: GaitParams = WALKING) -> GaitBuilder:
    """A builder that has walked *pieces* in turn; :class:`RecipeError` once the scenario would
    last longer than :data:`MAX_DURATION_S`, naming the piece that took it there."""
    b = GaitBuilder(params)
    for piece in pieces:
        try:
            piece.spec.walk(b, *piece.values)
        except ValueError as exc:
            raise RecipeError(f"{piece.label()}: {exc}") from None
        if b.t > MAX_DURATION_S:
            raise RecipeError(f"{piece.label()}: the scenario would last {b.t:.0f} s by its end: at most "
                              f"{MAX_DURATION_S:g} s (the walk's ground truth is held whole in memory)")
    return b
