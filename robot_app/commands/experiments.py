"""`robot-app trial` and `robot-app paper`: config-driven sweeps and the paper's experiments."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import typer

from robot_app.commands._options import AllowLargeOption, MaxMemoryOption, resource_limits
from robot_app.errors import InputError, RobotAppError


def _print_summary(summary: dict[str, Any], folder: Path) -> None:
    run = summary["run"]
    rate = run.get("trials_per_s")
    rate_text = f", {rate:.2f} trials/s" if rate else ""
    typer.echo(
        f"{summary['name']}: {summary['ok']} ok, {summary['failed']} failed of {summary['trials']} "
        f"({run['ran']} run now in {run['wall_time_s']:.1f} s{rate_text}, "
        f"{run['workers']} worker(s), {run['backend']})"
    )
    for name, value in summary.get("rates", {}).items():
        typer.echo(f"  {name}: {100 * value:.1f} %")
    for name, stats in summary.get("errors", {}).items():
        if stats["count"]:
            typer.echo(
                f"  {name}: mean {stats['mean']:+.2f}, std {stats['std']:.2f}, "
                f"mean±3σ [{stats['low']:+.2f}, {stats['high']:+.2f}] (n={stats['count']})"
            )
    for reason, count in summary.get("failure_reasons", {}).items():
        typer.echo(f"  failed x{count}: {reason}")
    typer.echo(f"results: {folder}")


ConfigArg = Annotated[Path, typer.Argument(metavar="CONFIG", help="Trial config YAML (configs/*.yaml).")]
TrialsOpt = Annotated[int | None, typer.Option("--trials", help="Number of trials (overrides the config).")]
WorkersOpt = Annotated[int, typer.Option("--workers", help="Worker processes (or CPUs of a local Ray).")]
BackendOpt = Annotated[str, typer.Option("--backend", help="local (process pool) or ray.")]
RayAddressOpt = Annotated[
    str, typer.Option("--ray-address", help="Ray cluster: auto (running), local (private), host:port.")
]
OutOpt = Annotated[Path | None, typer.Option("--out", help="Results folder [default: results/<name>].")]
SetOpt = Annotated[list[str] | None, typer.Option("--set", help="Override key.path=value (repeatable).")]
ProgressOpt = Annotated[bool, typer.Option("--progress/--no-progress", help="Show progress bars.")]
QuickOpt = Annotated[bool, typer.Option("--quick", help="A small version (a minute or two).")]
SourceOpt = Annotated[str, typer.Option("--source", help="Images: synthetic or sim (pybullet).")]


def register(app: typer.Typer) -> None:
    """Adds the `trial` and `paper` subcommands to `app`."""

    @app.command("trial")
    def trial(
        config_path: ConfigArg,
        trials: TrialsOpt = None,
        workers: WorkersOpt = 1,
        backend: BackendOpt = "local",
        ray_address: RayAddressOpt = "auto",
        out: OutOpt = None,
        overrides: SetOpt = None,
        progress: ProgressOpt = True,
        max_memory_gb: MaxMemoryOption = None,
        allow_large: AllowLargeOption = False,
    ) -> None:
        """Run seeded trials from a config; an existing folder of the same config is resumed.

        Ctrl-C (or SIGTERM) keeps every finished trial in trials.csv, writes summary.json
        with status 'interrupted' and exits 130 (143); the same command resumes.
        """
        from robot_app.experiments import load_trial_config, run_trials

        if backend not in ("local", "ray"):
            raise InputError(
                f"--backend must be local or ray, got {backend!r}", key="--backend", value=backend
            )
        settings = list(overrides or []) + ([f"trials={trials}"] if trials is not None else [])
        config = load_trial_config(config_path, settings)
        folder = out if out is not None else Path("results") / config.name
        backend_name: Literal["local", "ray"] = "ray" if backend == "ray" else "local"
        result = run_trials(
            config,
            folder,
            workers=workers,
            backend=backend_name,
            ray_address=ray_address,
            progress=progress,
            limits=resource_limits(max_memory_gb, allow_large),
        )
        _print_summary(result.summary, result.out_dir)
        if result.summary["ok"] == 0:
            raise RobotAppError(f"all {result.total} trials failed; see {result.out_dir / 'trials.csv'}")

    @app.command("paper")
    def paper(
        out: OutOpt = None,
        quick: QuickOpt = False,
        workers: WorkersOpt = 2,
        source: SourceOpt = "synthetic",
        overrides: SetOpt = None,
        progress: ProgressOpt = True,
        max_memory_gb: MaxMemoryOption = None,
        allow_large: AllowLargeOption = False,
    ) -> None:
        """Reproduce the paper's experiments (Fig. 11-13, identification) into a report folder.

        A folder holding a report of the same settings is resumed (its trial sweeps);
        Ctrl-C keeps what finished and exits 130 (143 on SIGTERM).
        """
        from robot_app.experiments import load_paper_config, run_paper

        settings = load_paper_config(quick=quick, source=source, overrides=list(overrides or []))
        report = run_paper(
            settings,
            out or Path("results/paper"),
            workers=workers,
            progress=progress,
            limits=resource_limits(max_memory_gb, allow_large),
        )
        typer.echo(report.table_markdown)
        typer.echo(f"report: {report.report_path} ({report.wall_time_s:.0f} s)")


__all__ = ["register"]
