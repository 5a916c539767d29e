"""`robot-app` command-line entry point.

Subcommands live in `robot_app/commands/` (one module per area, each with a
`register(app)` function) so that this file stays a thin switchboard. Every
`RobotAppError` becomes a one-line message on stderr and the error's exit code
(2 = bad input, 1 = a run that failed, 128 + signal = interrupted), and so does a usage
error of the command line; tracebacks are only shown with ROBOT_APP_DEBUG=1. Suspicious
inputs are `warning:` lines (`robot_app.console`).
"""

from __future__ import annotations

import sys
import warnings

import typer

from robot_app import __version__
from robot_app.commands import register_all
from robot_app.console import debug_enabled, show_warnings_as_lines
from robot_app.errors import InterruptError, RobotAppError
from robot_app.interrupts import interrupt_signal, signal_name, signals_raise_interrupts

app = typer.Typer(
    name="robot-app",
    help="Cloth-handling robot: photo-model-based recognition and pick-and-place with a PA10.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"robot-app {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
) -> None:
    """Cloth-handling robot: photo-model-based recognition and pick-and-place with a PA10."""


register_all(app)


def _report(err: RobotAppError) -> int:
    message = str(err).strip() or type(err).__name__
    if isinstance(err, InterruptError):
        typer.echo(f"interrupted: {message}", err=True)
    else:
        typer.echo(f"error: {message}", err=True)
    return err.exit_code


def _report_usage(err: typer.TyperException) -> int:
    """A usage error of the command line (unknown option, bad value) as one line."""
    if type(err).__name__ == "NoArgsIsHelpError":  # `robot-app` or a group without a command
        err.show()  # type: ignore[attr-defined]
        return 2
    context = getattr(err, "ctx", None)
    hint = f" (see '{context.command_path} --help')" if context is not None else ""
    message = " ".join(err.format_message().split())
    typer.echo(f"error: {message}{hint}", err=True)
    return int(getattr(err, "exit_code", 2))


def _run(argv: list[str] | None) -> int:
    try:
        result = app(args=argv, standalone_mode=False, prog_name="robot-app")
    except RobotAppError as err:
        if debug_enabled():
            raise
        return _report(err)
    except typer.Exit as err:
        return int(err.exit_code or 0)
    except typer.Abort:
        typer.echo("aborted", err=True)
        return 1
    except KeyboardInterrupt as err:  # outside a command's body (while parsing or importing)
        number = interrupt_signal(err)
        typer.echo(f"interrupted: {signal_name(number)}; nothing was written", err=True)
        return 128 + number
    except typer.TyperException as err:
        if debug_enabled():
            raise
        return _report_usage(err)
    except MemoryError:
        if debug_enabled():
            raise
        typer.echo(
            "error: out of memory; a smaller input (grid step, image, model, population) "
            "or a lower --max-memory-gb would have been refused before starting",
            err=True,
        )
        return 1
    # typer returns the code of a `typer.Exit` raised in a command (standalone_mode=False)
    return result if isinstance(result, int) else 0


def main(argv: list[str] | None = None) -> int:
    """Runs the CLI and returns its exit code.

    0 ok, 1 the job failed, 2 bad input (including an output path that cannot be
    written and an input over a resource limit), 128 + signal when interrupted (130
    Ctrl-C, 143 SIGTERM).
    """
    with signals_raise_interrupts(), warnings.catch_warnings():
        show_warnings_as_lines()
        return _run(argv)


if __name__ == "__main__":
    sys.exit(main())
