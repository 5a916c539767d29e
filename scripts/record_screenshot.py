"""A screenshot of the Rerun viewer showing an episode recording (the README's picture).

Records one episode (or takes an existing .rrd), starts the viewer that rerun-sdk ships
in headless mode, opens the recording with its stored layout, moves the time cursor and
saves what the viewer draws. Needs the `viewer` extra and a Vulkan driver; without a GPU
Mesa's software rasteriser works (Debian: `apt-get install mesa-vulkan-drivers`).

    python scripts/record_screenshot.py --out docs/images/rerun_episode.png --time 1.1
    python scripts/record_screenshot.py --recording run.rrd --out shot.png --time 3.5
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from robot_app.config import load_config
from robot_app.experiments.pick_place_episode import PickPlaceConfig, run_episode
from robot_app.outputs import atomic_path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--recording", type=Path, help="an existing .rrd (default: record seed --seed)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--time", type=float, default=1.1, help="cell time shown [s]")
    parser.add_argument("--port", type=int, default=9877, help="the viewer's gRPC port")
    parser.add_argument("--wait", type=float, default=8.0, help="seconds the viewer gets to draw")
    args = parser.parse_args()

    from rerun.experimental import ViewerClient

    with tempfile.TemporaryDirectory() as folder:
        recording = args.recording
        if recording is None:
            recording = Path(folder) / "episode.rrd"
            config = load_config(PickPlaceConfig, REPO / "configs" / "pick_place.yaml", [f"seed={args.seed}"])
            result = run_episode(config, record_path=recording).result
            print(
                f"recorded seed {args.seed}: {result.outcome.value}, {len(result.recognitions)} recognitions"
            )
        os.environ.setdefault("XDG_RUNTIME_DIR", folder)
        beside = Path(sys.executable).with_name("rerun")  # the venv's viewer, even if not on PATH
        client = ViewerClient.spawn(
            headless=True,
            port=args.port,
            hide_welcome_screen=True,
            executable_path=str(beside) if beside.exists() else None,
        )
        try:
            time.sleep(args.wait / 2)
            client.open(str(recording.resolve()))
            time.sleep(args.wait / 2)
            client.set_time("cell_time", duration=args.time, play_state="paused")
            time.sleep(args.wait)
            with atomic_path(args.out) as temporary:
                client.save_screenshot(str(temporary.resolve()))
                size = -1
                for _ in range(50):  # the viewer writes the file itself, a moment later
                    time.sleep(0.2)
                    now = temporary.stat().st_size if temporary.exists() else -1
                    if now > 0 and now == size:
                        break
                    size = now
        finally:
            client.quit()
    print(f"screenshot of the viewer at cell time {args.time:.2f} s: {args.out}")


if __name__ == "__main__":
    main()
