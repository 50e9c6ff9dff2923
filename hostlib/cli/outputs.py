"""What a walk or a replay leaves: the summary lines (what the aids did, each foot's stream, the
fusion of two feet) and the files the options ask for (CSV, GeoJSON, PNG)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping, Sequence
from typing import TextIO

from protocol.board import FOOT_SIDES

from ..errors import HostError
from ..fusion.feet import DISAGREEMENT_SIGMAS, TwoFeetTracker
from ..fusion.tracker import FusionTracker
from ..link.session import SessionStats
from ..run.aid_setup import AidSetup
from ..run.status import pose_text
from ..track.steps import Track

__all__ = ["aids_summary", "feet_summary", "finish_feet", "fusion_line", "stats_line", "write_outputs"]


def aids_summary(aids: AidSetup, out: TextIO) -> tuple[float, float, float] | None:
    """What the aids did, at the end of a walk; returns the track's geographic origin (the first
    fix's place; None without one)."""
    print(f"aids: {aids.describe()}", file=out)
    s = aids.tracker.aid_settings
    if s.compass or s.gps or isinstance(aids.tracker, TwoFeetTracker):  # one module's errors alone: none
        print(fusion_line(aids.tracker), file=out)
    return aids.origin if aids.gps_stats is not None else None


def fusion_line(tracker: FusionTracker | TwoFeetTracker) -> str:
    """What the aids did, for the summary (a FusionTracker or a TwoFeetTracker)."""
    f = tracker.fusion
    if tracker.aid_settings.compass and f.compass_updates == 0 and not f.heading_aligned_by:
        return ("fusion: no step packet carried the magnetometers and attitude — record with the fusion "
                "set-up (track and log send it unless --no-fusion); the track is the plain sum")
    aligned = f"heading aligned by {f.heading_aligned_by}" if f.heading_aligned_by else \
        "heading not aligned (the module's initial frame)"
    return (f"fusion: {f.compass_updates} compass updates ({f.compass_skipped} readings skipped"
            + (f", {f.compass_rejected} rejected by the innovation gate" if f.compass_rejected else "")
            + (f", {f.compass_field_rejected} rejected by the field check (the first: "
               f"{f.compass_field_first})" if f.compass_field_rejected else "")
            + (f", {f.compass_refused} not finite" if f.compass_refused else "") + "), "
            f"{f.gps_updates} GPS updates ({f.gps_skipped} fixes between updates, "
            f"{f.gps_before_alignment} before alignment); {aligned}; declination "
            f"{math.degrees(tracker.declination):+.2f}° ± {math.degrees(tracker.declination_sigma):.2f}°"
            + ("" if tracker.deviation is None else
               f"; local deviation at the end {math.degrees(tracker.deviation):+.2f}° ± "
               f"{math.degrees(tracker.deviation_sigma):.2f}°")
            + ("" if not tracker.iron_weight_rad > 0.0 else
               f"; uncalibrated compass weighed for its iron: {math.degrees(tracker.iron_weight_rad):.1f}° "
               f"(H {tracker.iron_weight_horizontal_ut:.1f} µT)")
            + ("" if "hard_iron" not in tracker.filter else
               "; hard iron at the end [{:+.2f}, {:+.2f}, {:+.2f}] ± [{:.2f}, {:.2f}, {:.2f}] µT".format(
                   *tracker.filter.mean("hard_iron"),
                   *tracker.filter.sigmas("hard_iron")))
            + ("" if tracker.compass_swing is None else
               "; compass swing at the end B {:+.2f} ± {:.2f}°, C {:+.2f} ± {:.2f}°".format(
                   *(math.degrees(float(v)) for pair in zip(tracker.compass_swing,
                                                            tracker.compass_swing_sigma, strict=True)
                     for v in pair)))
            + ("" if tracker.gps_bias is None else
               "; GPS bias at the end N {:+.2f} ± {:.2f} m, E {:+.2f} ± {:.2f} m".format(
                   *(float(v) for pair in zip(tracker.gps_bias, tracker.gps_bias_sigma, strict=True)
                     for v in pair))))


def write_outputs(args: argparse.Namespace, track: Track, origin: Sequence[float] | None,
                  geographic_csv: bool = False, feet: TwoFeetTracker | None = None) -> None:
    """The files the options ask for: *track*'s, or with *feet* the body track's (its CSV with each
    foot's columns, its plot with each fused foot's path). A file that cannot be written (checked
    before the walk, :func:`~hostlib.cli.checks.value_refusal`, but a disk may fill) is a
    :class:`~hostlib.errors.HostError` naming it."""
    try:
        _write_outputs(args, track, origin, geographic_csv, feet)
    except OSError as exc:
        raise HostError(f"cannot write {exc.filename or 'an output file'}: {exc.strerror or exc}") from None


def _write_outputs(args: argparse.Namespace, track: Track, origin: Sequence[float] | None,
                   geographic_csv: bool, feet: TwoFeetTracker | None) -> None:
    if args.csv:
        from ..files.export import write_csv, write_feet_csv

        if feet is not None:
            write_feet_csv(feet, args.csv, origin if geographic_csv else None)
        else:
            write_csv(track, args.csv, origin if geographic_csv else None)
    if args.geojson:
        from ..files.export import write_geojson

        write_geojson(track, args.geojson, origin)
    if args.png:
        from ..files.plot import PlotOptions, plot_track

        paths = None if feet is None else {f"{side} foot": feet.fused_foot(side) for side in FOOT_SIDES}
        title = None if feet is None else (f"body of two feet: {len(track)} steps, {track.distance:.1f} m, "
                                           f"closure {track.closure_error():.2f} m")
        plot_track(track, args.png, PlotOptions(every=args.every, paths=paths, title=title,
                                                label="track" if feet is None else "body"))


def stats_line(stats: SessionStats) -> str:
    """A session's counters: packets, resends, garbage, bad frames, gaps."""
    return (f"packets {stats.packets} (+{stats.duplicate_packets} resends) "
            f"| garbage {stats.garbage_bytes} B | bad frames {stats.bad_frames} "
            f"| gaps {stats.gaps} (missing {stats.missing_steps})"
            + (f" | {stats.undecoded_packets} packets fit no layout the capture's commands set up"
               if stats.undecoded_packets else ""))


def feet_summary(tracker: TwoFeetTracker, streams: Mapping[str, tuple[str, SessionStats]]) -> list[str]:
    """The summary of a two-feet walk: per foot (side → (where its stream came from, its session's
    counters)) its steps, distance, gaps and duplicates; what the fusion did; the body's end, fused
    and as the average of the two single-module tracks."""
    lines = []
    for side, (name, stats) in streams.items():
        foot = tracker.foot(side)
        lines.append(f"{side} foot ({name}): {len(foot)} step packets, {foot.track.motion_steps} steps, "
                     f"{foot.distance:.2f} m, duplicates {foot.duplicates} | {stats_line(stats)}")
    settings = tracker.settings
    restarts = ", ".join(f"{side} at fused step {k}" for side, k in tracker.restarts) or "none"
    constraint = (f"constraint γ {settings.max_separation_m:.2f} m, projections {tracker.projections}"
                  if settings.constraint else "constraint off")
    lines.append(f"fusion: {len(tracker)} steps (left {tracker.sides.count('left')}, right "
                 f"{tracker.sides.count('right')}) | {constraint} | steps with a stale foot "
                 f"{tracker.stale_steps} | steps longer than 2γ {tracker.long_steps} | restarts: {restarts}")
    for side, calibration in tracker.drift.items():
        lines.append(f"drift correction, {side} foot: {calibration}")
    if tracker.drift_uncorrected:
        lines.append(f"drift correction: {tracker.drift_uncorrected} steps had no swing time and are "
                     f"uncorrected (record with the fusion set-up)")
    for what, track in (("fused", tracker.body), ("average", tracker.average)):
        label = f"body ({what}):"
        lines.append(f"{label:16s}{pose_text(track.final_pose, track.closure_sigma())} "
                     f"| {track.distance:.2f} m")
    apart, sigmas = tracker.disagreement()
    if sigmas > DISAGREEMENT_SIGMAS:
        remedy = ("hold each module's errors: leave out --no-module-errors"
                  if tracker.aids.module_errors is None
                  else "errors beyond their priors: --module-errors with the modules' own")
        lines.append(f"warning: the fused body and the average end {apart:.2f} m apart, {sigmas:.1f}σ of "
                     "their covariances: the constraint moved the walker more than either allows (a bound "
                     f"too tight for the gait, or modules whose headings drift apart: {remedy})")
    return lines


def finish_feet(args: argparse.Namespace, tracker: TwoFeetTracker,
                streams: Mapping[str, tuple[str, SessionStats]], origin: Sequence[float] | None,
                out: TextIO) -> None:
    """A two-feet walk's output files and summary (:func:`feet_summary`); with GPS its CSV places
    the body on the globe too, as one foot's does."""
    write_outputs(args, tracker.body, origin, geographic_csv=bool(args.gps), feet=tracker)
    for line in feet_summary(tracker, streams):
        print(line, file=out)
