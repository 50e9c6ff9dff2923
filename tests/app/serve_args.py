"""The options ``openshoe-emu serve`` parses, for tests of what it makes of them."""

from __future__ import annotations

import argparse


def serve_args(*argv: str) -> argparse.Namespace:
    """*argv* parsed as ``openshoe-emu serve``'s options."""
    from firmware_sim.app.serve import add_arguments

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return parser.parse_args(argv)
