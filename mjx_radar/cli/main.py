"""The ``mjx-radar`` command line (SPEC §11).

Exit codes: 0 success; 2 bad input (one line on stderr, no traceback, no result
files); 1 anything else. Sub-commands live in their own modules, each with
``add_arguments(parser)`` and ``main(args) -> int``; this module only parses,
dispatches and turns input errors into exit code 2.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import sys

from mjx_radar.errors import InputError

COMMANDS = {
    "validate": ("mjx_radar.cli.commands", "check a scenario file"),
    "run": ("mjx_radar.cli.commands", "run the closed loop on a scenario"),
    "study": ("mjx_radar.cli.study", "Monte Carlo study over scenarios and methods (resumable)"),
    "report": ("mjx_radar.cli.report", "figures and tables of a study directory"),
    "render": ("mjx_radar.cli.render", "render a saved run to MP4/GIF"),
    "snapshot": ("mjx_radar.cli.snapshot", "two-panel scene + FIM heat-map figure of a run"),
}


COMPILING = ("run", "study")  # sub-commands that compile XLA programs


def add_cache_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("compilation cache")
    g.add_argument(
        "--cache-dir",
        default=None,
        help="persistent XLA compilation cache (default $MJX_RADAR_CACHE_DIR or "
        "~/.cache/mjx_radar/xla)",
    )
    g.add_argument("--no-cache", action="store_true", help="compile without the persistent cache")
    p.add_argument(
        "--precision",
        choices=("float32", "float64"),
        default="float32",
        help="floating-point precision of the simulation (float64: x64 mode, slower)",
    )


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse prints usage otherwise)
        raise InputError(f"{self.prog}: {message}")


def _quiet_mujoco_import() -> None:
    """Imports MJX with its optional-backend chatter ('Failed to import warp') silenced."""
    with contextlib.redirect_stdout(io.StringIO()):
        importlib.import_module("mujoco.mjx")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mjx-radar", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as err:
            if err.name != module:
                raise
            p.set_defaults(missing=module)
            continue
        getattr(mod, f"add_{name}_arguments", getattr(mod, "add_arguments", None))(p)
        if name in COMPILING:
            add_cache_arguments(p)
        p.set_defaults(handler=getattr(mod, f"{name}_main", getattr(mod, "main", None)))
    return parser


def main(argv: list[str] | None = None) -> int:
    from mjx_radar.viz.gl import configure

    configure(argv)  # MUJOCO_GL must be set before anything imports mujoco
    from mjx_radar.io.scenario import ScenarioError

    try:
        args = build_parser().parse_args(argv)
        if getattr(args, "missing", None):
            print(
                f"mjx-radar {args.command}: not available in this version "
                f"(module {args.missing} is not implemented)",
                file=sys.stderr,
            )
            return 1
        if args.command in COMPILING and args.precision == "float64":
            import jax

            jax.config.update("jax_enable_x64", True)  # before any array exists
        _quiet_mujoco_import()
        if args.command in COMPILING and not args.no_cache:
            from mjx_radar.simulation import compile_cache

            compile_cache.enable(args.cache_dir)
        return int(args.handler(args) or 0)
    except (InputError, ScenarioError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
