"""Parse commands with their own parsers, in a process of its own: ``python parse_commands.py``
reads ``[[parser, [arg, …]], …]`` as JSON on stdin (parser: ``module:function``) and prints, as
JSON, one error text per command (empty: it parsed). A function named ``main`` is a command that
builds its parser inside its ``main``: the parser is caught when it starts to parse."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import json
import sys


class _Parsed(Exception):
    pass


def parse(target: str, args: list[str]) -> str:
    module, _, function = target.partition(":")
    make = getattr(importlib.import_module(module), function)
    err = io.StringIO()
    original = argparse.ArgumentParser.parse_args
    if function == "main":
        def parse_only(self, argv=None, namespace=None):
            original(self, argv, namespace)
            raise _Parsed

        argparse.ArgumentParser.parse_args = parse_only  # type: ignore[method-assign]
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            if function == "main":
                make(args)
            else:
                make().parse_args(args)
    except _Parsed:
        pass
    except SystemExit as exc:
        if exc.code not in (0, None):
            return err.getvalue().strip() or f"exit {exc.code}"
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]
    return ""


if __name__ == "__main__":
    jobs = json.load(sys.stdin)
    print(json.dumps([parse(target, args) for target, args in jobs]))
