"""Mobile ground radars re-positioned by MPPI over MuJoCo-MJX rollouts to track drones.

Exit codes: 0 success; 1 failure (e.g. diverged trials, results written); 2 bad
input, an unusable ``--out`` or a run too large for the machine (one line on
stderr, no traceback, no result files); 130 interrupted (Ctrl-C, no partial
result files). Sub-commands live in their own modules, each with
``add_arguments(parser)`` and ``main(args) -> int``; this module only parses,
dispatches and turns input errors into exit code 2.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import sys

from mjx_radar.errors import EXIT_INPUT, EXIT_INTERRUPTED, InputError

COMMANDS = {
    "validate": ("mjx_radar.cli.validate", "check a scenario file"),
    "run": ("mjx_radar.cli.run", "run the closed loop on a scenario"),
    "study": ("mjx_radar.cli.study", "Monte Carlo study over scenarios and methods (resumable)"),
    "report": ("mjx_radar.cli.report", "figures and tables of a study directory"),
    "render": ("mjx_radar.cli.render", "render a saved run to MP4/GIF"),
    "snapshot": ("mjx_radar.cli.snapshot", "two-panel scene + FIM heat-map figure of a run"),
    "view": ("mjx_radar.cli.view", "interactive 3-D view of a saved run (one offline HTML file)"),
}


COMPILING = ("run", "study")  # sub-commands that compile XLA programs
LIGHT = ("validate", "report", "view")  # sub-commands that never simulate (no MJX import)


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
    p.add_argument(
        "--deterministic",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="deterministic GPU kernels (XLA's --xla_gpu_deterministic_ops; on by default "
        "unless XLA_FLAGS turns it off): the same numbers from every compilation, run to "
        "run and on any number of GPUs, and faster compiles; --no-deterministic: XLA's "
        "autotuned kernels, whose numbers differ between cold compilations (docs/scaling.md)",
    )


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse prints usage otherwise)
        raise InputError(f"{self.prog}: {message}")


@contextlib.contextmanager
def _quiet():
    """Swallows stdout and stderr chatter of imports (MJX prints 'Failed to import warp')."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        yield


def _version() -> str:
    from mjx_radar.version import __version__

    return f"mjx-radar {__version__}"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mjx-radar", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        try:
            with _quiet():
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
    from mjx_radar.scenario.reader import ScenarioError
    from mjx_radar.viz import gl

    # imageio-ffmpeg starts ffmpeg with preexec_fn=os.setpgrp, which runs Python in a
    # fork of this multithreaded (JAX) process: JAX warns "os.fork() was called ...
    # will likely lead to a deadlock", rightly. Without preexec_fn, subprocess spawns
    # ffmpeg without running Python in the child (no at-fork hooks, no warning); Ctrl-C
    # then also reaches ffmpeg, which is what an interrupted render wants anyway.
    os.environ.setdefault("IMAGEIO_FFMPEG_NO_PREVENT_SIGINT", "1")
    try:
        gl.configure(argv)  # MUJOCO_GL must be set before anything imports mujoco
        args = build_parser().parse_args(argv)
        if getattr(args, "missing", None):
            print(
                f"mjx-radar {args.command}: not available in this version "
                f"(module {args.missing} is not implemented)",
                file=sys.stderr,
            )
            return 1
        if args.command in COMPILING:  # before JAX starts its backend (GPUs only)
            from mjx_radar.engine import determinism

            determinism.request_in_env(args.deterministic)
        if args.command == "run":  # before JAX starts its backend (GPUs only)
            from mjx_radar.engine import resources

            resources.allocate_gpu_memory_on_demand()
        if args.command in COMPILING and args.precision == "float64":
            import jax

            jax.config.update("jax_enable_x64", True)  # before any array exists
        if args.command not in LIGHT:  # reads MUJOCO_GL (MJX itself: on first use)
            with _quiet():
                importlib.import_module("mujoco")
        gl.restore()
        if args.command in COMPILING and not args.no_cache:
            from mjx_radar.engine import compile_cache

            compile_cache.enable(args.cache_dir)
        return int(args.handler(args) or 0)
    except (InputError, ScenarioError) as err:
        if getattr(err, "frames", ""):  # a plug-in's own exception: the user's frames
            print(err.frames, file=sys.stderr)
        print(f"error: {err}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def entry() -> None:
    """The ``mjx-radar`` command: :func:`main`, then exit without waiting for a program
    still compiling in the background (a run refused after its programs had started,
    e.g. radars that cannot be placed: XLA cannot be stopped, and the process would sit
    until it finished). :func:`main` itself returns (tests call it in-process)."""
    code = main()
    threads = sys.modules.get("mjx_radar.engine.threads")  # imported if anything compiled
    if threads is not None and threads.busy():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()
