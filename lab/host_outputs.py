"""Record what the host SDK (``openshoe-host``) outputs over fixed captures, and prove later that
not one number changed.

    python lab/host_outputs.py record --captures DIR --out DIR [--repo R] [--data D]
    python lab/host_outputs.py compare --captures DIR --baseline DIR --out DIR [--repo R] [--data D]

``record`` first makes the captures if ``--captures`` is missing or empty: short simulated walks
written by the emulator (``python -m firmware_sim.app.cli replay ...``, see CAPTURES), with their
GPS logs, the simulated shoe's iron, a two-feet walk (one capture per foot) and three closed loops
of one module; their argv and SHA-256 go to ``captures.json`` beside them. It then runs the host
(``python -m hostlib.cli ...``, see RUNS) over them, one sub-folder of ``--out`` per run, holding
every file the run wrote (CSV, GeoJSON, PNG, calibration JSON, the emulator's wire where a run
makes one) and, per step, its stdout, stderr and exit status (``stepN.stdout.txt``,
``stepN.stderr.txt``, ``stepN.exit.txt``). ``manifest.json`` in ``--out`` lists every run's argv,
as a template (``{captures}``, ``{out}``, ``{run}``, ``{data}``) and as run, and the captures'
hashes. Runs of the real recordings (``--data``, default /work/shared/data/openshoe-walks) are
skipped with a message when those files are absent.

``compare`` checks that the captures still have the hashes of the baseline's manifest, re-runs
exactly the manifest's runs into ``--out`` and compares every file with the baseline's. It prints
one line per run, ``same`` or ``DIFFERENT`` with the first differences, and exits 1 on any
difference (2 when it cannot run).

Every command runs with the interpreter running this script, in ``--repo`` (default: the
current directory), with ``--repo`` first on PYTHONPATH, so the tree pointed at is the one
measured. The environment is cleaned of ``OPENSHOE_*`` variables, and each run gets its own empty
magnetometer-calibration folder (``OPENSHOE_MAGCAL_DIR`` and ``XDG_CONFIG_HOME`` inside the run's
folder), so no calibration saved elsewhere on the machine leaks into a run; MPLBACKEND is Agg and
PYTHONHASHSEED 0.

How files are compared (lab/output_comparison.py):

* Paths are made neutral first: the out folder, the captures folder, the data folder, the repo
  and the interpreter are replaced by placeholders in every text, so paths that differ only by
  those prefixes are equal.
* CSV: the same rows and header; cells equal as text, or both numbers equal within relative
  1e-9 (absolute 1e-12 near zero); integers must be equal exactly.
* JSON and GeoJSON: the same structure and keys; numbers as in a CSV, strings and booleans
  exactly. (Degrees of latitude and longitude at relative 1e-9 are about 6 mm; the CSVs hold the
  same tracks in metres.)
* PNG: the pixel data (IHDR, PLTE, tRNS, pHYs and the decompressed IDAT) exactly; the text chunks
  (the "Software: Matplotlib version" line) and tIME are ignored.
* Other text (stdout, stderr, exit status, NMEA): line by line, the words exactly and the
  numbers in them as in a CSV.
* Anything else (the emulator's wire bytes): byte for byte.

What is ignored because it is not deterministic, and only that:

* in the emulator's stderr, the wall-clock figure of ``N samples in X s`` (masked as ``X``);
* the one-time notices of numba's compile, ``preparing the compiled tracking path (first run only,
  ...)`` and ``compiled tracking path ready (X s)`` (the lines are dropped), which appear only on
  a tree's first run;
* the PNG text chunks above.

Not covered, on purpose: the live commands (``track``, ``log``, ``info``) on ``openshoe://`` URLs.
The emulated module there runs in virtual time driven by the host's reads from another thread, so
two identical runs differ (the first packet's timestamp, which magnetometer readings a calibration
gets, which status lines are printed); they cannot be compared to 1e-9. No run combines
``--compass`` or ``--origin`` with the World Magnetic Model without ``--gps`` or
``--declination``: the declination would then be taken at today's date.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

if __package__:
    from .output_comparison import (
        ABS_TOL,
        MAX_DIFFS,
        REL_TOL,
        as_text,
        compare_bytes,
        compare_csv,
        compare_json,
        compare_png,
        compare_text,
    )
else:  # run as a script (python lab/host_outputs.py): this folder is first on sys.path
    from output_comparison import (
        ABS_TOL,
        MAX_DIFFS,
        REL_TOL,
        as_text,
        compare_bytes,
        compare_csv,
        compare_json,
        compare_png,
        compare_text,
    )

DEFAULT_DATA = "/work/shared/data/openshoe-walks"
ORIGIN = "58.3949,15.5728,90"
MODULES = {"host": "hostlib.cli", "emu": "firmware_sim.app.cli"}

#: The emulator's captures: name → argv after ``python -m firmware_sim.app.cli``.
CAPTURES = {
    "walk": ["replay", "--scenario", "walk", "--seed", "1", "--wire", "{captures}/walk.bin"],
    "mixed": ["replay", "--scenario", "mixed", "--seed", "2", "--host", "fusion", "--height-compensation",
              "--wire", "{captures}/mixed.bin"],
    "outage": ["replay", "--scenario", "navshoe-outage", "--seed", "1", "--host", "fusion",
               "--wire", "{captures}/outage.bin", "--gps", "{captures}/outage.nmea"],
    "calibration": ["replay", "--scenario", "navshoe-calibration", "--seed", "1", "--host", "fusion",
                    "--calibrate-mag", "--wire", "{captures}/calibration.bin",
                    "--gps", "{captures}/calibration.nmea", "--origin", ORIGIN],
    "feet": ["replay", "--scenario", "rectangle", "--seed", "1", "--module", "3", "--feet", "2",
             "--host", "fusion", "--wire", "{captures}/feet.bin", "--gps", "{captures}/feet.nmea",
             "--origin", ORIGIN, "--gps-outage", "40:60"],
    "loops": ["replay", "--scenario", "rectangle", "--seeds", "1:4", "--module", "7", "--host", "fusion",
              "--wire-dir", "{captures}/loops"],
}

#: The files of the captures the runs read (their hashes are checked before a comparison).
CAPTURE_FILES = [
    "walk.bin", "mixed.bin", "outage.bin", "outage.nmea", "outage.bin.iron.json",
    "calibration.bin", "calibration.nmea", "feet.bin.left", "feet.bin.right", "feet.nmea",
    "feet.bin.left.iron.json", "feet.bin.right.iron.json",
    *(f"loops/rectangle_module7_seed{s}.bin" for s in (1, 2, 3)),
    "loops/rectangle_module7_seed3.bin.iron.json",
]

C = "{captures}"
LOOP = C + "/loops/rectangle_module7_seed"
DRIFT_CAL = "{out}/drift-calibrate/drift.json"
INSITU_DIR = "{out}/magcal-in-situ/magcal"
FEET = [C + "/feet.bin.left", C + "/feet.bin.right"]
FEET_IRON = [C + "/feet.bin.left.iron.json", C + "/feet.bin.right.iron.json"]
TRACK_CSV = ["--csv", "{run}/track.csv"]
TRACK_GEO = ["--geojson", "{run}/track.geojson"]
TRACK_PNG = ["--png", "{run}/track.png"]


def _run(name: str, *steps: list[str], expect: int = 0, data: bool = False) -> dict:
    """One run: its steps (``host ...`` or ``emu ...``), the exit status its last step should
    have, and whether it reads the shared real recordings."""
    return {"name": name, "steps": [list(s) for s in steps], "expect_exit": expect, "needs_data": data}


def _replay(*args: str) -> list[str]:
    return ["host", "replay", *args]


#: Every run, in order (later runs read earlier runs' calibrations).
RUNS = [
    # (1) plain replay: the plain step sum (--no-module-errors), then the default host without an aid
    # (the module's errors held at mimu22bt's priors; on the plain capture its warm-up not counted)
    _run("plain-walk", _replay(C + "/walk.bin", "--no-module-errors", *TRACK_CSV, *TRACK_GEO,
                               "--origin", ORIGIN, *TRACK_PNG, "--every", "5")),
    _run("plain-mixed", _replay(C + "/mixed.bin", "--no-module-errors", *TRACK_CSV, *TRACK_GEO)),
    _run("plain-outage", _replay(C + "/outage.bin", "--no-module-errors", *TRACK_CSV)),
    _run("default-walk", _replay(C + "/walk.bin", *TRACK_CSV, *TRACK_PNG, "--every", "5")),
    _run("default-mixed", _replay(C + "/mixed.bin", *TRACK_CSV)),
    # (2) compass and GPS with every aid
    _run("aids-all-wmm", _replay(C + "/outage.bin", "--compass", "--compass-deviation", "outdoors",
                                 "--gps", C + "/outage.nmea", "--gps-bias",
                                 "--module-errors", "emulated-sway", "--mag-cal", C + "/outage.bin.iron.json",
                                 *TRACK_CSV, *TRACK_GEO, *TRACK_PNG)),
    _run("aids-all-given", _replay(C + "/outage.bin", "--compass", "--compass-sigma", "2",
                                   "--compass-deviation", "4,12", "--gps", C + "/outage.nmea", "--gps-bias",
                                   "--module-errors", "0.001,0.0017,0.01,20,0.05,120",
                                   "--mag-cal", C + "/outage.bin.iron.json", "--declination", "6.5",
                                   *TRACK_CSV, *TRACK_GEO)),
    _run("aids-compass", _replay(C + "/outage.bin", "--compass", "--compass-sigma", "5",
                                 "--mag-cal", C + "/outage.bin.iron.json", *TRACK_CSV)),
    _run("aids-gps", _replay(C + "/outage.bin", "--gps", C + "/outage.nmea", *TRACK_CSV, *TRACK_GEO)),
    _run("aids-module-errors", _replay(C + "/mixed.bin", "--module-errors", "emulated-still", *TRACK_CSV)),
    # (3) in-situ magnetometer calibration, then the saved calibration applied
    _run("magcal-in-situ", _replay(C + "/calibration.bin", "--compass", "--compass-sigma", "5",
                                   "--calibrate-mag", "--mag-cal-dir", "{run}/magcal", *TRACK_CSV)),
    _run("magcal-in-situ-aids", _replay(C + "/calibration.bin", "--compass", "--calibrate-mag",
                                        "--mag-cal-dir", "{run}/magcal", "--compass-deviation", "outdoors",
                                        "--gps", C + "/calibration.nmea", "--gps-bias",
                                        "--module-errors", "emulated-sway", *TRACK_CSV, *TRACK_GEO)),
    _run("magcal-saved", _replay(C + "/calibration.bin", "--compass", "--compass-sigma", "5",
                                 "--mag-cal-dir", INSITU_DIR, *TRACK_CSV)),
    _run("magcal-file", _replay(C + "/calibration.bin", "--compass", "--compass-deviation", "outdoors",
                                "--gps", C + "/calibration.nmea",
                                "--mag-cal", INSITU_DIR + "/OPENSHOE-EMU-01.json", *TRACK_CSV)),
    # (5) drift: calibrate, then apply (before the two-feet runs, which use the calibration)
    _run("drift-calibrate", ["host", "drift", "calibrate", LOOP + "1.bin", LOOP + "2.bin",
                             "-o", "{run}/drift.json"]),
    _run("drift-calibrate-one", ["host", "drift", "calibrate", LOOP + "3.bin", "-o", "{run}/drift.json"]),
    _run("drift-apply", _replay(LOOP + "3.bin", "--drift", DRIFT_CAL, *TRACK_CSV, *TRACK_GEO)),
    _run("drift-apply-aids", _replay(LOOP + "3.bin", "--drift", DRIFT_CAL, "--compass",
                                     "--mag-cal", LOOP + "3.bin.iron.json", "--module-errors", "emulated",
                                     *TRACK_CSV)),
    _run("drift-refused", _replay(C + "/walk.bin", "--drift", DRIFT_CAL), expect=1),
    # (4) two feet
    _run("feet-plain", _replay(*FEET, *TRACK_CSV, *TRACK_GEO, *TRACK_PNG)),
    _run("feet-no-constraint", _replay(*FEET, "--no-constraint", *TRACK_CSV)),
    _run("feet-separation", _replay(*FEET, "--max-separation", "0.4", *TRACK_CSV)),
    _run("feet-aids", _replay(*FEET, "--compass", "--compass-deviation", "indoors", "--gps", C + "/feet.nmea",
                              "--gps-bias", "--module-errors", "emulated-sway", "--mag-cal", *FEET_IRON,
                              *TRACK_CSV, *TRACK_GEO, *TRACK_PNG)),
    _run("feet-aids-one-cal", _replay(*FEET, "--compass", "--compass-sigma", "10", "--mag-cal", FEET_IRON[0],
                                      "-", "--declination", "3", "--max-separation", "1.5", *TRACK_CSV)),
    _run("feet-drift", _replay(*FEET, "--drift", "-", DRIFT_CAL, *TRACK_CSV)),
    _run("feet-swapped-refused", _replay(*FEET, "--compass", "--mag-cal", *reversed(FEET_IRON)), expect=1),
    # (6) the emulator's batch replay of shared real recordings, then the host
    _run("real-walk-plain", ["emu", "replay", "{data}/walk_100521_2.txt", "--wire", "{run}/walk.bin"],
         _replay("{run}/walk.bin", *TRACK_CSV, *TRACK_GEO), data=True),
    _run("real-walk-compass", ["emu", "replay", "{data}/walk_100521_3.txt", "--host", "fusion",
                               "--wire", "{run}/walk.bin"],
         _replay("{run}/walk.bin", "--compass", *TRACK_CSV), data=True),
]

#: Lines dropped and figures masked before text is compared (the module docstring says why).


# ---------------------------------------------------------------------------------------------
# running commands


class Places:
    """The folders a run's argv and outputs refer to, and their placeholders."""

    def __init__(self, repo: Path, captures: Path, out: Path, data: Path, *, recorded_out: Path | None = None,
                 python: str = sys.executable) -> None:
        self.repo, self.captures, self.out, self.data = repo, captures, out, data
        #: the out folder as the outputs name it (a baseline may have been moved since) and the interpreter
        self.recorded_out, self.python = recorded_out or out, python

    def fill(self, text: str, run: str = "") -> str:
        """A template with its placeholders replaced by this place's folders."""
        return text.format(captures=self.captures, out=self.out, run=self.out / run, data=self.data)

    def neutral(self, text: str) -> str:
        """*text* with this place's folders and interpreter replaced by placeholders."""
        pairs = [(str(self.recorded_out), "{out}"), (str(self.captures), "{captures}"),
                 (str(self.data), "{data}"), (str(self.repo), "{repo}"), (self.python, "{python}")]
        for path, name in sorted(pairs, key=lambda p: -len(p[0])):
            text = text.replace(path, name)
        return text


def command(step: list[str], places: Places, run: str = "") -> list[str]:
    """The argv of one step: the interpreter, ``-m`` the tool's module, the filled arguments."""
    tool, *args = step
    return [sys.executable, "-m", MODULES[tool], *(places.fill(a, run) for a in args)]


def environment(repo: Path, run_dir: Path | None) -> dict[str, str]:
    """The subprocesses' environment: the repo first on PYTHONPATH, no OPENSHOE_* settings of the
    caller, a calibration folder of the run's own."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENSHOE_")}
    env["PYTHONPATH"] = os.pathsep.join([str(repo), *filter(None, [os.environ.get("PYTHONPATH")])])
    env.update(MPLBACKEND="Agg", PYTHONIOENCODING="utf-8", PYTHONHASHSEED="0")
    if run_dir is not None:
        env["OPENSHOE_MAGCAL_DIR"] = str(run_dir / "magcal")
        env["XDG_CONFIG_HOME"] = str(run_dir / "xdg-config")
    return env


def execute_run(spec: dict, places: Places) -> tuple[list[int], float]:
    """Run every step of *spec* into a fresh ``out/<name>``; returns the exit codes and seconds."""
    run_dir = places.out / spec["name"]
    if run_dir.exists():
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    env, codes, start = environment(places.repo, run_dir), [], time.monotonic()
    for i, step in enumerate(spec["steps"], 1):
        argv, stem = command(step, places, spec["name"]), run_dir / f"step{i}"
        with open(f"{stem}.stdout.txt", "wb") as out, open(f"{stem}.stderr.txt", "wb") as err:
            code = subprocess.run(argv, cwd=places.repo, env=env, stdout=out, stderr=err,
                                  stdin=subprocess.DEVNULL).returncode
        (run_dir / f"step{i}.exit.txt").write_text(f"{code}\n")
        codes.append(code)
    return codes, time.monotonic() - start


def status_word(spec: dict, codes: list[int]) -> str:
    """``ok`` when every step but the last exited 0 and the last as expected."""
    wanted = [0] * (len(codes) - 1) + [spec["expect_exit"]]
    return "ok" if codes == wanted else f"UNEXPECTED exit {codes} (wanted {wanted})"


# ---------------------------------------------------------------------------------------------
# captures


def sha256(path: Path) -> str:
    """The SHA-256 of a file, read in blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def capture_hashes(captures: Path) -> dict[str, str]:
    """The hashes of the captures the runs read; a missing file is an error that names it."""
    missing = [name for name in CAPTURE_FILES if not (captures / name).is_file()]
    if missing:
        raise SystemExit(f"{captures}: missing captures {', '.join(missing)} (an empty folder is filled "
                         "by `record`)")
    return {name: sha256(captures / name) for name in CAPTURE_FILES}


def make_captures(places: Places) -> dict:
    """Write the emulator's captures into an empty captures folder, with ``captures.json``."""
    places.captures.mkdir(parents=True, exist_ok=True)
    env, made, start = environment(places.repo, None), {}, time.monotonic()
    env["OPENSHOE_MAGCAL_DIR"] = env["XDG_CONFIG_HOME"] = str(places.captures / ".no-saved-calibration")
    for name, args in CAPTURES.items():
        argv = command(["emu", *args], places)
        t0 = time.monotonic()
        done = subprocess.run(argv, cwd=places.repo, env=env, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"capture {name} failed ({done.returncode}): {' '.join(argv)}\n{done.stderr}")
        made[name] = {"argv": argv, "seconds": round(time.monotonic() - t0, 1)}
        print(f"capture {name:12s} {made[name]['seconds']:6.1f} s  {' '.join(args)}", flush=True)
    shutil.rmtree(places.captures / ".no-saved-calibration", ignore_errors=True)
    info = {"captures": made, "seconds": round(time.monotonic() - start, 1),
            "sha256": capture_hashes(places.captures)}
    (places.captures / "captures.json").write_text(json.dumps(info, indent=1) + "\n")
    return info


# ---------------------------------------------------------------------------------------------
# record


def runnable(spec: dict, places: Places) -> str | None:
    """Why *spec* cannot run here (None when it can)."""
    if spec["needs_data"]:
        for step in spec["steps"]:
            for arg in step:
                if arg.startswith("{data}") and not Path(places.fill(arg)).is_file():
                    return f"real recording {places.fill(arg)} is not readable here"
    return None


def run_all(runs: list[dict], places: Places) -> list[dict]:
    """Run *runs* in order, printing a line each; returns the manifest's run entries."""
    entries = []
    for spec in runs:
        codes, seconds = execute_run(spec, places)
        files = sorted(str(p.relative_to(places.out / spec["name"]))
                       for p in (places.out / spec["name"]).rglob("*") if p.is_file())
        print(f"{spec['name']:24s} {seconds:5.1f} s  {status_word(spec, codes)}  "
              f"({len(files)} files)", flush=True)
        argv = [command(step, places, spec["name"]) for step in spec["steps"]]
        entries.append({**spec, "argv": argv, "exit": codes, "seconds": round(seconds, 2), "files": files})
    return entries


def cmd_record(args: argparse.Namespace) -> int:
    """``record``: make the captures if needed, run everything, write the manifest."""
    places = make_places(args, args.out)
    start = time.monotonic()
    if not places.captures.exists() or not any(places.captures.iterdir()):
        make_captures(places)
    hashes = capture_hashes(places.captures)
    runs, skipped = [], []
    for spec in RUNS:
        reason = runnable(spec, places)
        if reason is None:
            runs.append(spec)
            continue
        skipped.append({"name": spec["name"], "reason": reason})
        print(f"{spec['name']:24s} skipped: {reason}")
    places.out.mkdir(parents=True, exist_ok=True)
    entries = run_all(runs, places)
    seconds = time.monotonic() - start
    write_manifest(places, entries, skipped, hashes, seconds)
    bad = [e["name"] for e in entries if status_word(e, e["exit"]) != "ok"]
    print(f"recorded {len(entries)} runs in {seconds:.1f} s → {places.out}/manifest.json"
          + (f"; unexpected exit status: {', '.join(bad)}" if bad else ""))
    return 1 if bad else 0


def write_manifest(places: Places, entries: list[dict], skipped: list[dict], hashes: dict,
                   seconds: float) -> None:
    """The manifest: where things were, the captures' hashes, every run's argv."""
    manifest = {"format": "openshoe-host-outputs", "version": 1, "python": sys.executable,
                "repo": str(places.repo), "captures": str(places.captures), "out": str(places.out),
                "data": str(places.data), "tolerance": {"relative": REL_TOL, "absolute": ABS_TOL},
                "seconds": round(seconds, 1), "capture_sha256": hashes, "runs": entries, "skipped": skipped}
    (places.out / "manifest.json").write_text(json.dumps(manifest, indent=1, ensure_ascii=False) + "\n")


def make_places(args: argparse.Namespace, out: str) -> Places:
    return Places(Path(args.repo).resolve(), Path(args.captures).resolve(), Path(out).resolve(),
                  Path(args.data).resolve())


# ---------------------------------------------------------------------------------------------
# comparing a run's files (each kind of file: lab/output_comparison.py)


def compare_file(a: Path, b: Path, base: Places, new: Places, name: str) -> list[str]:
    """Compare one output file of a run with its baseline, by its kind."""
    da, db = a.read_bytes(), b.read_bytes()
    if a.suffix == ".png":
        return compare_png(da, db, name)
    ta, tb = as_text(da), as_text(db)
    if ta is None or tb is None:
        return compare_bytes(da, db, name)
    ta, tb = base.neutral(ta), new.neutral(tb)
    if a.suffix == ".csv":
        return compare_csv(ta, tb, name)
    if a.suffix in (".json", ".geojson"):
        return compare_json(ta, tb, name)
    return compare_text(ta, tb, name)


def files_of(folder: Path) -> set[str]:
    """The files under *folder*, relative to it (none when it is missing)."""
    if not folder.is_dir():
        return set()
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}


def compare_run(name: str, base: Places, new: Places) -> list[str]:
    """Every difference (the first few) between a run's baseline folder and its new one."""
    fa, fb = files_of(base.out / name), files_of(new.out / name)
    diffs = [f"only in the baseline: {f}" for f in sorted(fa - fb)]
    diffs += [f"only in the new run: {f}" for f in sorted(fb - fa)]
    for f in sorted(fa & fb):
        if len(diffs) >= MAX_DIFFS:
            break
        diffs += compare_file(base.out / name / f, new.out / name / f, base, new, f)
    return diffs[:MAX_DIFFS]


# ---------------------------------------------------------------------------------------------
# compare


def load_manifest(baseline: Path) -> dict:
    path = baseline / "manifest.json"
    if not path.is_file():
        raise SystemExit(f"{path}: no manifest (make one with `record`)")
    return json.loads(path.read_text())


def check_captures(manifest: dict, places: Places) -> None:
    """Refuse to compare over captures other than the baseline's."""
    now = capture_hashes(places.captures)
    changed = [name for name, digest in manifest["capture_sha256"].items() if now.get(name) != digest]
    if changed:
        raise SystemExit(f"{places.captures}: not the baseline's captures ({', '.join(changed)} differ)")


def baseline_places(manifest: dict, baseline: Path) -> Places:
    """Where the baseline was recorded (its out folder is wherever it is now)."""
    return Places(Path(manifest["repo"]), Path(manifest["captures"]), baseline.resolve(),
                  Path(manifest["data"]), recorded_out=Path(manifest["out"]), python=manifest["python"])


def cmd_compare(args: argparse.Namespace) -> int:
    """``compare``: the manifest's runs again, on this tree, then every file against the baseline."""
    baseline = Path(args.baseline)
    manifest = load_manifest(baseline)
    base, new = baseline_places(manifest, baseline), make_places(args, args.out)
    check_captures(manifest, new)
    for skip in manifest["skipped"]:
        print(f"{skip['name']:24s} not in the baseline: {skip['reason']}")
    start = time.monotonic()
    new.out.mkdir(parents=True, exist_ok=True)
    runs = [{k: r[k] for k in ("name", "steps", "expect_exit", "needs_data")} for r in manifest["runs"]]
    entries, different = [], 0
    for spec in runs:
        entry, diffs = compare_one(spec, base, new)
        entries.append(entry)
        different += bool(diffs)
    seconds = time.monotonic() - start
    write_manifest(new, entries, manifest["skipped"], manifest["capture_sha256"], seconds)
    verdict = "all same" if not different else f"{different} DIFFERENT"
    print(f"{len(runs)} runs in {seconds:.1f} s: {verdict} (baseline {baseline}, this run {new.out})")
    return 1 if different else 0


def compare_one(spec: dict, base: Places, new: Places) -> tuple[dict, list[str]]:
    """Run one manifest run on this tree and compare it; prints its line."""
    reason = runnable(spec, new)
    if reason:
        print(f"{spec['name']:24s} DIFFERENT: cannot run: {reason}")
        return {**spec, "argv": [], "exit": [], "seconds": 0.0, "files": []}, [reason]
    codes, seconds = execute_run(spec, new)
    diffs = compare_run(spec["name"], base, new)
    print(f"{spec['name']:24s} {seconds:5.1f} s  " + ("same" if not diffs else "DIFFERENT"), flush=True)
    for d in diffs:
        print(f"    {d}")
    files = sorted(files_of(new.out / spec["name"]))
    argv = [command(step, new, spec["name"]) for step in spec["steps"]]
    return {**spec, "argv": argv, "exit": codes, "seconds": round(seconds, 2), "files": files}, diffs


# ---------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    commands = (("record", "make the captures if needed, run the host over them, save the outputs"),
                ("compare", "re-run a record's runs on this tree and compare with it"))
    for name, helptext in commands:
        s = sub.add_parser(name, help=helptext)
        s.add_argument("--captures", required=True, help="folder of the emulator's captures")
        s.add_argument("--out", required=True, help="folder for the runs' outputs and manifest.json")
        s.add_argument("--repo", default=".", help="the tree to run (default: the current directory)")
        s.add_argument("--data", default=DEFAULT_DATA, help="the shared real recordings")
        if name == "compare":
            s.add_argument("--baseline", required=True, help="the --out of a `record`")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return cmd_record(args) if args.cmd == "record" else cmd_compare(args)


if __name__ == "__main__":
    sys.exit(main())
