"""What `--record` (and `--video`) cost: wall time of whole episodes with and without them.

Runs the same seeded pick-and-place episodes (configs/pick_place.yaml) in this process,
alternating plain and recorded runs so that drifting machine load hits both alike, and
prints per-episode times, the medians, the extra wall time of a recorded episode
(target: <= 15 %), the recording's size, and the one-time cost of importing rerun
(paid once per process, before the first recording). A recorded episode must be the
same episode: its outcome and recognitions are compared with the plain run's.

    taskset -c 0 python scripts/bench_recording.py --seeds 0 1 2 --repeats 2
    taskset -c 0 python scripts/bench_recording.py --seeds 0 --video   # the MP4's cost too

The machine load (1-minute average) and the CPUs this process may run on are printed;
pin it with `taskset` on a shared machine and compare medians.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from robot_app.config import load_config
from robot_app.control.episode import EpisodeResult
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode

REPO = Path(__file__).resolve().parents[1]
TARGET = 0.15


def _episode(
    config: PickPlaceConfig, record_path: Path | None = None, video_path: Path | None = None
) -> tuple[float, float, EpisodeResult]:
    """Wall time [s], CPU time of this process's threads [s], the result."""
    start, cpu = time.perf_counter(), time.process_time()
    episode = run_episode(config, record_path=record_path, video_path=video_path)
    return time.perf_counter() - start, time.process_time() - cpu, episode.result


def _same(a: EpisodeResult, b: EpisodeResult) -> bool:
    return (a.outcome, len(a.recognitions), a.commanded_samples) == (
        b.outcome,
        len(b.recognitions),
        b.commanded_samples,
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--repeats", type=int, default=2, help="pairs (plain, recorded) per seed")
    parser.add_argument("--video", action="store_true", help="also time episodes with --video")
    parser.add_argument("--config", type=Path, default=REPO / "configs" / "pick_place.yaml")
    args = parser.parse_args()
    print(f"CPUs allowed: {sorted(os.sched_getaffinity(0))}; load average {os.getloadavg()[0]:.2f}")

    start = time.perf_counter()
    import rerun  # noqa: F401  (what the first recording of a process pays)

    print(f"import rerun: {time.perf_counter() - start:.2f} s (once per process)")
    base = load_config(PickPlaceConfig, args.config, [])
    warm = base.model_copy(update={"seed": args.seeds[0]})
    with tempfile.TemporaryDirectory() as folder:
        _episode(warm, record_path=Path(folder) / "warm.rrd")  # JIT compilation, caches
        plain, recorded, video, sizes = [], [], [], []
        cpu_plain, cpu_recorded = [], []
        for seed in args.seeds:
            config = base.model_copy(update={"seed": seed})
            for repeat in range(args.repeats):
                target = Path(folder) / f"seed{seed}-{repeat}.rrd"
                order = ("plain", "record") if repeat % 2 == 0 else ("record", "plain")
                times: dict[str, float] = {}
                cpu: dict[str, float] = {}
                results: dict[str, EpisodeResult] = {}
                for kind in order:
                    path = target if kind == "record" else None
                    times[kind], cpu[kind], results[kind] = _episode(config, record_path=path)
                if not _same(results["plain"], results["record"]):
                    raise SystemExit(f"seed {seed}: the recorded episode differs from the plain one")
                plain.append(times["plain"])
                recorded.append(times["record"])
                cpu_plain.append(cpu["plain"])
                cpu_recorded.append(cpu["record"])
                sizes.append(target.stat().st_size / 1e6)
                r = results["plain"]
                print(
                    f"seed {seed} #{repeat}: plain {times['plain']:.2f} s, recorded {times['record']:.2f} s "
                    f"({times['record'] / times['plain'] - 1:+.1%}; "
                    f"CPU {cpu['plain']:.2f} -> {cpu['record']:.2f} s); "
                    f"{r.outcome.value}, "
                    f"{len(r.recognitions)} recognitions, {r.sim_time:.1f} s simulated; "
                    f"{sizes[-1]:.1f} MB; load {os.getloadavg()[0]:.2f}"
                )
            if args.video:
                seconds, _, result = _episode(config, video_path=Path(folder) / f"seed{seed}.mp4")
                frames = round(result.sim_time * 20)
                video.append((seconds, frames))
                print(f"seed {seed}: with --video {seconds:.2f} s, ~{frames} frames")
    mp, mr = statistics.median(plain), statistics.median(recorded)
    extra = mr / mp - 1
    ratio = statistics.median(r / p - 1 for r, p in zip(recorded, plain, strict=True))
    print(
        f"median wall time of an episode: plain {mp:.2f} s, recorded {mr:.2f} s: {extra:+.1%} "
        f"(median of the pairs' ratios {ratio:+.1%}); target <= {TARGET:.0%}: "
        f"{'met' if extra <= TARGET else 'NOT met'}"
    )
    cp, cr = statistics.median(cpu_plain), statistics.median(cpu_recorded)
    print(
        f"median CPU time (all threads of this process): plain {cp:.2f} s, recorded {cr:.2f} s: "
        f"{cr / cp - 1:+.1%}"
    )
    print(
        f"recording size: median {statistics.median(sizes):.1f} MB; load average now {os.getloadavg()[0]:.2f}"
    )
    if video:
        per_frame = statistics.median((s - mp) / f for s, f in video)
        print(
            f"--video: median {statistics.median(s for s, _ in video):.2f} s per episode, "
            f"~{1e3 * per_frame:.0f} ms per frame over the plain episode (960x480, 20 frames per simulated s)"
        )


if __name__ == "__main__":
    main()
