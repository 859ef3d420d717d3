"""``mnss-kit`` command line.

Each subcommand lives in its stage as a ``command`` module with ``HELP``,
``add_arguments(parser)`` and ``run(args)``.  A stage that is not present in
this installation simply has no subcommand.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import logging
import sys

from . import __version__
from .errors import UserError

# subcommand -> module, in pipeline order
COMMANDS = {
    "demo": "mnss_kit.demo",
    "render": "mnss_kit.render.command",
    "data": "mnss_kit.dataset.command",
    "models": "mnss_kit.model.command",
    "train": "mnss_kit.train.command",
    "eval": "mnss_kit.eval.command",
    "finetune": "mnss_kit.finetune.command",
    "quantize": "mnss_kit.quantize.command",
    "split": "mnss_kit.split.command",
    "export": "mnss_kit.export.command",
    "bundle": "mnss_kit.export.bundle_command",
    "emulate": "mnss_kit.emulate.command",
    "bench": "mnss_kit.bench.command",
    "stress": "mnss_kit.stress.command",
    "size": "mnss_kit.size.command",
    "report": "mnss_kit.report.command",
}


def available_commands() -> dict[str, str]:
    return {name: mod for name, mod in COMMANDS.items() if importlib.util.find_spec(mod) is not None}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mnss-kit",
        description="Neural supersampling for phones: render, train, evaluate, quantize, split, export, emulate.",
    )
    parser.add_argument("--version", action="version", version=f"mnss-kit {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging on stderr")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, modname in available_commands().items():
        mod = importlib.import_module(modname)
        p = sub.add_parser(name, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        code = args._run(args)
    except UserError as e:
        print(f"mnss-kit {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"mnss-kit {args.command}: interrupted", file=sys.stderr)
        return 130
    return int(code or 0)


def main_or_exit(argv: list[str]) -> None:
    """:func:`main` for scripts that chain commands: ``SystemExit`` naming the command when it fails."""
    code = main(argv)
    if code:
        raise SystemExit(f"mnss-kit {' '.join(argv)} failed with exit code {code}")


if __name__ == "__main__":
    sys.exit(main())
