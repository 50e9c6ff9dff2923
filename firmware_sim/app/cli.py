"""`openshoe-emu`: the emulator's command line (thin argparse wiring; the work is elsewhere).

Each subcommand lives in its own module with ``add_arguments(parser)`` and
``main(args) -> int``; add one by appending to :data:`SUBCOMMANDS`. A run imports only the
module of the subcommand it runs (``--help`` and a mistyped command import none).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

#: name → (module implementing it, one-line help).
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "serve": ("firmware_sim.app.serve", "run emulated modules in real time on a pty and/or TCP port"),
    "replay": ("firmware_sim.app.replay_cli",
               "replay recordings or scenarios in batch mode; write the wire bytes"),
    "sweep": ("firmware_sim.app.sweep",
              "sweep recordings or scenarios × seeds × settings (Dask); a results table"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The whole parser; with *command*, only that subcommand's options (the others listed by
    name and help, their modules not imported)."""
    parser = argparse.ArgumentParser(prog="openshoe-emu", description="The OpenShoe module emulator.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (modname, help_text) in SUBCOMMANDS.items():
        if command is not None and name != command:
            sub.add_parser(name, help=help_text)
            continue
        module = importlib.import_module(modname)
        p = sub.add_parser(name, help=help_text, description=(module.__doc__ or help_text).split("\n\n")[0])
        module.add_arguments(p)
        p.set_defaults(_main=module.main)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # the top level has no options but --help: the first other word names the subcommand
    command = next((a for a in argv if not a.startswith("-")), "")
    args = build_parser(command).parse_args(argv)
    return int(args._main(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
