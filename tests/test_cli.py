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


def test_the_cli_imports_no_simulator_or_controller_until_a_command_needs_them() -> None:
    # Every command imports the CLI; `recognize` on image files should not pay for
    # pybullet, Pinocchio's IK stack, filterpy and scipy.stats (~2.5 s of imports).
    code = (
        "import sys, robot_app.cli; "
        "print(sorted(m for m in ('pybullet', 'robot_app.control', 'robot_app.sim', 'filterpy', "
        "'robot_app.experiments.pick_place_episode') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
