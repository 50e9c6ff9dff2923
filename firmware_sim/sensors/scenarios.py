"""Named motion scenarios, composable with a tiny recipe language.

A *recipe* is a ``+``-separated list of pieces, each ``name[:arg[:arg]]``::

    stand:5+walk:20+arc:2:90+stairs_up:12+turn:-180+run:50+stand:3

Pieces (arguments optional, defaults in brackets):

==================================  ===========================================================
``stand[:s=3]``                     foot flat and still for s seconds
``walk[:m=10[:deg=0]]``             straight walk of m metres (along the ground), on a slope of deg
                                    (uphill > 0): the foot lands flat, pitch = deg, roll 0
``ramp[:m=50[:deg=6[:across=0]]]``  straight walk of m metres (along the ground) on a plane
                                    of slope deg whose uphill direction lies ``across`` degrees to
                                    the left of the walking direction (0: up the fall line, 90:
                                    along the contour with the ground falling to the right, 180:
                                    down). The foot lands flat on the plane: pitch θ = atan(tan deg
                                    · cos across), roll φ = atan(tan deg · sin across · cos θ)
                                    (right side down > 0); it rises tan deg · cos across per
                                    horizontal metre
``run[:m=50]``                      straight run (short stance, heel strikes clip at ±16 g)
``arc[:r=2[:deg=90]]``              walk along an arc of radius r, turning deg (right > 0)
``turn[:deg=90]``                   turn on the spot (right > 0), the foot flat on the ground it
                                    stands on (on a slope, pitch and roll follow the plane)
``stairs_up[:n=12]``                climb n stairs (rise 0.17 m, tread 0.28 m)
``stairs_down[:n=12]``              descend n stairs
``side[:n=4[:dir=1]]``              n side steps, to the right (dir 1) or left (dir −1)
``back[:n=4]``                      n steps backwards
``rectangle[:l=30[:w=15[:r=1]]]``   once round a rounded rectangle, turning right
``track400[:laps=1]``               laps of a 400 m running track (lane 1), turning left
``pace[:v=1.55]``                   from here on, walk at v m/s (stride length follows)
``face[:deg=0]``                    first piece only: the walker starts facing deg (east of north)
``wiggle[:s=30[:deg=90]]``          about s seconds of turning the foot in place through many
                                    orientations (heading all round, pitch and roll up to ±deg),
                                    each turn held still for a moment, ending flat where it began:
                                    the in-situ magnetometer calibration (aids.md §3)
==================================  ===========================================================

Every scenario starts and ends at rest (a recipe that does not start with
``stand`` gets ``stand:3`` in front, so the firmware's initial alignment can
complete; one that does not end with ``stand`` gets ``stand:2`` at the end).

Every number is checked before anything is walked (:mod:`.recipes`, which says why each range):
finite, and within its piece's range — a length m or a stand's s > 0, a piece's distance (an arc's
r · deg, a rectangle's perimeter) at most 2.5 km, a slope within ±30°, a turn within ±3600°, a
heading within ±360°, a pace from 0.3 to 3 m/s, a wiggle of at most 600 s tilting 0–90°, whole
counts of 1–2000 stairs, 1–1000 side or back steps (dir 1 or −1) and 1–6 laps, a rectangle's
corner radius at most half its shorter side; at most 1000 pieces, and the whole scenario at most
1800 s long. A refused recipe raises :class:`~.recipes.RecipeError` (a ValueError, and a KeyError
for an unknown name) that names the piece, its number and the range: ``piece 2 'walk:-5': the
length m [m] must be > 0 and at most 2500, got -5``.
:data:`SCENARIOS` names the standard ones; :func:`trajectory` accepts a name
or a recipe, :func:`feet` both feet of a walker walking it (the recipe is the body's path,
:mod:`~firmware_sim.sensors.feet`). :func:`environment` says where a named scenario is walked: indoors (a
building's magnetic deviation, the default) or outdoors, and whether its GPS receiver
loses the sky after some distance.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import recipes
from .feet import STEP_WIDTH_M, Feet, feet_from_body
from .gait import WALKING, GaitParams, Trajectory
from .gait_builder import GaitBuilder
from .recipes import PIECE_SPECS, RecipeError

__all__ = ["OUTAGE_LOOP", "SCENARIOS", "PIECES", "Environment", "RecipeError", "check", "environment", "feet",
           "list_scenarios", "recipe", "trajectory"]

_LAP = (
    "walk:36+arc:2:90+walk:16+arc:2:90+walk:8+stairs_up:12+walk:6.28+stairs_down:12+walk:15"
    "+arc:2:90+walk:16+arc:2:90"
)

#: NavShoe's outage loop after its start (aids.md §2): a hilly closed loop of about 1 km. Sides of
#: 300 m (a 3° hill up and down; a 2° hill and 99.7 m of flat, the same 299.6 m across) and 200 m
#: joined by 5 m arcs: 1031 m, back at the start within centimetres
OUTAGE_LOOP = ("walk:150:3+walk:150:-3+arc:5:90+walk:200+arc:5:90+walk:100:2+walk:100:-2+walk:99.71"
               "+arc:5:90+walk:200+arc:5:90+stand:5")

#: name → recipe.
SCENARIOS: dict[str, str] = {
    # the demo: align, two laps (≈ 233 m) of a 40 × 20 m block over a footbridge, stand
    "default": f"stand:5+{_LAP}+{_LAP}+stand:5",
    "stand": "stand:10",
    "walk": "stand:3+walk:100+stand:2",
    "walk_slow": "stand:3+pace:1.0+walk:30+stand:2",
    "walk_fast": "stand:3+pace:2.0+walk:50+stand:2",
    "rectangle": "stand:3+rectangle:30:15:1+stand:2",
    "track400": "stand:3+track400:1+stand:2",
    "turn_on_spot": "stand:3+turn:360+turn:-360+stand:2",
    "stairs_up": "stand:3+walk:3+stairs_up:16+walk:3+stand:2",
    "stairs_down": "stand:3+walk:3+stairs_down:16+walk:3+stand:2",
    "slope": "stand:3+walk:20:6+walk:5+walk:20:-6+stand:2",
    "side_steps": "stand:3+side:6:1+side:6:-1+stand:2",
    "back_steps": "stand:3+back:8+stand:2",
    "run": "stand:3+run:100+stand:2",
    "mixed": "stand:3+walk:10+turn:90+side:3+back:3+arc:3:-90+stairs_up:8+walk:2+stairs_down:8"
             "+run:20+stand:2",
    # the roads of the foot-angle height experiment (aids.md §5: 0°, 2.5°, 6.1°, 7.5°): from
    # level ground 50 m (along the road) up, a half turn on the spot on the slope, 50 m back
    # down to where the slope began; ramp_6 is the 6.1° road
    "ramp_0": "stand:3+walk:50:0+turn:180+walk:50:0+stand:2",
    "ramp_2.5": "stand:3+walk:50:2.5+turn:180+walk:50:-2.5+stand:2",
    "ramp_6": "stand:3+walk:50:6.1+turn:180+walk:50:-6.1+stand:2",
    "ramp_7.5": "stand:3+walk:50:7.5+turn:180+walk:50:-7.5+stand:2",
    # the diagonal walks: 50 m up a 7.8° road at 45° to its fall line (uphill ahead-left),
    # a half turn on the slope, and back the same way
    "ramp_diagonal": "stand:3+ramp:50:7.8:45+turn:180+ramp:50:7.8:-135+stand:2",
    # NavShoe's outage experiment (aids.md §2): the loop outdoors (OUTAGE_LOOP), started facing
    # north-east; the receiver gives no fix after the first 400 m (ENVIRONMENTS)
    "navshoe-outage": "face:50+stand:5+" + OUTAGE_LOOP,
    # the same loop with NavShoe's in-situ calibration first (aids.md §3): the wearer wiggles the
    # shoe for 30 s where the loop starts, stands, and walks off; the first stride ends the
    # calibration, and one capture calibrates and navigates (openshoe-host replay --calibrate-mag)
    "navshoe-wiggle-outage": "face:50+stand:5+wiggle:30+stand:3+" + OUTAGE_LOOP,
    # NavShoe's in-situ magnetometer calibration (aids.md §3): standing outdoors facing 30°, the
    # wearer wiggles the shoe for 30 s, stands, then walks 76 m with three turns; the first stride
    # (1.5 m) ends the calibration
    "navshoe-calibration": "face:30+stand:5+wiggle:30+stand:3+walk:20+arc:3:90+walk:15+arc:3:90"
                           "+walk:20+turn:-90+walk:12+stand:3",
    # NavShoe's house walk (aids.md §1): 118 m through a two-storey house, indoors without GPS
    # (ENVIRONMENTS), back to the front door within millimetres. Doorways are turns on the spot,
    # corridor corners short arcs; the wearer stops for a few seconds in four rooms
    "navshoe-house": (
        # ground floor: the hall, a corridor, through a door to the living room's window; back
        # through the dining room, once round its table, into the corridor and round to the stairs
        "stand:5+walk:3+arc:0.75:90+walk:3+turn:-90+walk:6+arc:1:90+walk:3+stand:3"
        "+turn:90+walk:4.5+arc:1.2:-360+turn:90+walk:2+turn:-90+walk:3.5+arc:0.75:-180"
        # a flight of 16 stairs up (2.72 m, one storey), then the upper floor's loop: the landing,
        # a corridor with the bathroom and the study off it, a bedroom (round the bed), through
        # the second bedroom and back to the top of the stairs, and down the same flight
        "+stairs_up:16+walk:1.5+turn:-90+walk:3+turn:-90+walk:2.5+stand:3+turn:180+walk:2.5"
        "+turn:-90+walk:3+turn:-90+walk:3+stand:2+turn:180+walk:3+turn:-90"
        "+arc:0.75:90+walk:3+arc:1:90+walk:4+stand:3+arc:1.2:360+walk:2+arc:1:90+walk:2.5"
        "+turn:90+walk:1.25+turn:-90+walk:2.75+stairs_down:16"
        # ground floor again: the kitchen, its pantry and back, the hall to the front door
        "+walk:1+turn:-90+walk:3+arc:1:90+walk:3+arc:1:90+walk:5+stand:3"
        "+turn:-90+walk:2.5+turn:180+walk:2.5+turn:-90+walk:3+arc:1:90+walk:2.25+turn:-90+walk:1.25"
        "+turn:90+stand:5"
    ),
}


@dataclass(frozen=True)
class Environment:
    """Where a scenario is walked."""

    #: open ground: the magnetic deviation varies slowly, by a few degrees
    #: (:meth:`~firmware_sim.sensors.config.MagConfig.outdoors`), not a building's tens of degrees
    outdoors: bool = False
    #: the GPS receiver gives no fix once the walker has gone this far [m] (None: never)
    gps_outage_after_m: float | None = None


#: name → environment of the scenarios not walked indoors with the sky always in view.
ENVIRONMENTS: dict[str, Environment] = {
    "navshoe-outage": Environment(outdoors=True, gps_outage_after_m=400.0),
    "navshoe-wiggle-outage": Environment(outdoors=True, gps_outage_after_m=400.0),
    # outdoors: the field is the same within the few centimetres the wiggle moves the module
    # (open ground varies over tens of metres, a building's over a few), so the readings lie on
    # one ellipsoid, and the compass on the walk after it measures the calibration, not a building
    "navshoe-calibration": Environment(outdoors=True),
    # a building's deviation (the default, MagConfig: 5 µT per axis varying over 3 m — about 20°
    # RMS of heading, correlated 0.2 a metre away, not at all a stride away, and about 0.4 a storey
    # up), and no sky: not one fix
    "navshoe-house": Environment(gps_outage_after_m=0.0),
}


def environment(name_or_recipe: str) -> Environment:
    """The environment of a named scenario (a recipe's is the default: indoors, GPS throughout)."""
    return ENVIRONMENTS.get(name_or_recipe, Environment())


#: name → the piece: its numbers, their ranges, how it is walked (:mod:`.recipes`).
PIECES = PIECE_SPECS


def list_scenarios() -> list[str]:
    """Names of the standard scenarios."""
    return sorted(SCENARIOS)


def recipe(name_or_recipe: str) -> str:
    """The recipe of a named scenario, or the argument itself when it starts as a recipe does
    (its pieces are checked when walked: :func:`check`); :class:`~.recipes.RecipeError` otherwise."""
    if name_or_recipe in SCENARIOS:
        return SCENARIOS[name_or_recipe]
    head = name_or_recipe.split("+")[0].split(":")[0].strip()
    if head in PIECES:
        return name_or_recipe
    raise RecipeError(f"unknown scenario {name_or_recipe!r}; known: {', '.join(list_scenarios())} "
                      f"(or a recipe of pieces {', '.join(sorted(PIECES))})")


def check(name_or_recipe: str) -> None:
    """Refuse a scenario that is no name and no recipe that can be walked (:class:`~.recipes.RecipeError`,
    naming the piece, the number and its range) without computing the walk: milliseconds."""
    _walked(name_or_recipe, WALKING)


def trajectory(name_or_recipe: str, params: GaitParams = WALKING) -> Trajectory:
    """Build the foot trajectory of a named scenario or a recipe."""
    return _walked(name_or_recipe, params).build()


def feet(name_or_recipe: str, params: GaitParams = WALKING, step_width: float = STEP_WIDTH_M) -> Feet:
    """Both feet of a walker walking a named scenario or a recipe
    (:mod:`~firmware_sim.sensors.feet`): the recipe is the body's path."""
    return feet_from_body(_walked(name_or_recipe, params), step_width)


def _walked(name_or_recipe: str, params: GaitParams) -> GaitBuilder:
    """A builder that has walked the scenario's pieces, with a stand added at either end
    (module docstring); :class:`~.recipes.RecipeError` for a piece that is refused."""
    pieces = recipes.parse(recipe(name_or_recipe))
    lead = 1 if pieces and pieces[0].name == "face" else 0  # the start's heading comes first
    if len(pieces) == lead or pieces[lead].name != "stand":
        pieces.insert(lead, recipes.parse_piece("stand:3", 0))
    if pieces[-1].name != "stand":
        pieces.append(recipes.parse_piece("stand:2", 0))
    return recipes.walk(pieces, params)
