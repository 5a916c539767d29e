import subprocess
import sys

from robot_app import __version__
from robot_app.cli import main


def test_version_and_help(capsys) -> None:
    assert main(["--version"]) == 0
    assert __version__ in capsys.readouterr().out
    assert main(["--help"]) == 0


def test_unknown_command_is_bad_input() -> None:
    assert main(["no-such-command"]) == 2


def test_console_script_runs() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "robot_app.cli", "--version"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0 and __version__ in out.stdout
