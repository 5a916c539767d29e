"""Measures ruckig's calculation time per (re)planning on random PA10 motions, and counts
limit violations on every commanded sample.

Offline: point-to-point trajectories between random joint configurations (wall time of
`ruckig.calculate` through the binding). Online: a target that jumps to a random
configuration every second and moves along a sinusoid in between, replanned every
control cycle (ruckig's own timing of each replan, and the wall time of `step()`).

    python scripts/bench_trajectory.py [--motions 500] [--seconds 60] [--dt 0.004] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from robot_app.control.limits import JointLimits, LimitReport, check_limits
from robot_app.control.online_trajectory import OnlineTrajectory
from robot_app.control.trajectory import plan_point_to_point

URDF = Path(__file__).resolve().parents[1] / "urdf" / "pa10.urdf"


def offline(limits: JointLimits, motions: int, dt: float, rng: np.random.Generator) -> None:
    times_us, reports = [], []
    for _ in range(motions):
        q_start, q_goal = (rng.uniform(limits.lower, limits.upper) for _ in range(2))
        trajectory = plan_point_to_point(q_start, q_goal, limits, dt=dt)
        times_us.append(trajectory.calculation_time_s * 1e6)
        samples = trajectory.samples(dt)
        reports.append(check_limits(*samples, limits))
        if np.max(np.abs(samples.Q[-1] - q_goal)) > 1e-9:
            raise SystemExit("offline trajectory missed its goal")
    print_times(f"offline: {motions} point-to-point motions, ruckig.calculate wall time", times_us)
    print_report(reports)


def online(limits: JointLimits, seconds: float, dt: float, rng: np.random.Generator) -> None:
    middle, half_range = (limits.upper + limits.lower) / 2, (limits.upper - limits.lower) / 2
    trajectory = OnlineTrajectory(limits, dt, middle)
    start = trajectory.state
    T, Q, V, A = [start.time], [start.q], [start.v], [start.a]
    step_us = []
    amplitude, omega = 0.1, 2.0  # [rad], [rad/s]: 0.2 rad/s, 0.4 rad/s^2 on every joint
    phase = rng.uniform(0, 2 * np.pi, limits.dof)
    for k in range(1, round(seconds / dt) + 1):
        t = k * dt
        if k % round(1.0 / dt) == 1:  # a new random centre every second
            centre = middle + rng.uniform(-0.8, 0.8, limits.dof) * (half_range - amplitude)
        angle = omega * t + phase
        trajectory.set_target(
            centre + amplitude * np.sin(angle),
            amplitude * omega * np.cos(angle),
            -amplitude * omega**2 * np.sin(angle),
        )
        started = time.perf_counter()
        sample = trajectory.step()
        step_us.append((time.perf_counter() - started) * 1e6)
        T.append(sample.time), Q.append(sample.q), V.append(sample.v), A.append(sample.a)
    replans = trajectory.calculation_times * 1e6
    print_times(f"online: {len(step_us)} cycles of {dt * 1e3:g} ms, ruckig's timing of each replan", replans)
    print_times("online: wall time of OnlineTrajectory.step() (binding + checks)", step_us)
    print_report([check_limits(np.array(T), np.array(Q), np.array(V), np.array(A), limits)])


def print_times(title: str, values_us: list[float] | np.ndarray) -> None:
    values = np.asarray(values_us)
    print(
        f"{title}\n  n={values.size}  median={np.median(values):.1f} us  "
        f"p99={np.percentile(values, 99):.1f} us  worst={values.max():.1f} us"
    )


def print_report(reports: list[LimitReport]) -> None:
    samples = sum(r.samples for r in reports)
    counts = {
        kind: sum(getattr(r, kind) for r in reports)
        for kind in ("position", "velocity", "acceleration", "jerk")
    }
    worst = {
        kind: max(getattr(r, f"worst_{kind}") for r in reports)
        for kind in ("velocity", "acceleration", "jerk")
    }
    print(f"  limit violations on {samples} commanded samples: {counts}")
    print("  worst |value| / limit: " + ", ".join(f"{k} {v:.12f}" for k, v in worst.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motions", type=int, default=500, help="offline point-to-point motions")
    parser.add_argument("--seconds", type=float, default=60.0, help="online run length [s]")
    parser.add_argument("--dt", type=float, default=0.004, help="control period [s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--urdf", type=Path, default=URDF)
    args = parser.parse_args()
    limits = JointLimits.from_urdf(args.urdf)
    print(
        f"PA10 limits from {args.urdf} (safety-scaled): "
        f"velocity {np.round(limits.velocity, 3).tolist()} rad/s"
    )
    rng = np.random.default_rng(args.seed)
    offline(limits, args.motions, args.dt, rng)
    online(limits, args.seconds, args.dt, rng)


if __name__ == "__main__":
    main()
