"""`robot-app` command-line entry point.

Subcommands live in `robot_app/commands/` (one module per area, each with a
`register(app)` function) so that this file stays a thin switchboard. Every
`RobotAppError` becomes a one-line message on stderr and the error's exit code
(2 = bad input, 1 = a run that failed); tracebacks are only shown with ROBOT_APP_DEBUG=1.
"""

from __future__ import annotations

import os
import sys

import typer

from robot_app import __version__
from robot_app.commands import register_all
from robot_app.errors import RobotAppError

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


def main(argv: list[str] | None = None) -> int:
    """Runs the CLI and returns its exit code (0 ok, 1 failure, 2 bad input)."""
    try:
        app(args=argv, standalone_mode=False)
    except RobotAppError as err:
        if os.environ.get("ROBOT_APP_DEBUG"):
            raise
        message = str(err).strip() or type(err).__name__
        typer.echo(f"error: {message}", err=True)
        return err.exit_code
    except typer.Exit as err:
        return int(err.exit_code or 0)
    except typer.Abort:
        typer.echo("aborted", err=True)
        return 1
    except KeyboardInterrupt:
        typer.echo("interrupted", err=True)
        return 130
    except Exception as err:
        # Usage errors of the (vendored) click inside typer: show them like click does.
        if hasattr(err, "show") and hasattr(err, "exit_code"):
            err.show()
            return 2
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main())
