"""Writing a calibrated rig file: `vision.camera`'s YAML with a header saying where it came from."""

from __future__ import annotations

from pathlib import Path

import yaml

from robot_app.outputs import atomic_write_text
from robot_app.vision.camera import StereoRig


def rig_yaml(rig: StereoRig, comment_lines: tuple[str, ...] = ()) -> str:
    """The rig's YAML text (what `save_rig` writes) under `# ...` comment lines."""
    header = "".join(f"# {line}\n" for line in comment_lines)
    return header + yaml.safe_dump(rig.to_dict(), sort_keys=False)


def write_rig(rig: StereoRig, path: str | Path, comment_lines: tuple[str, ...] = ()) -> Path:
    """Writes the rig file atomically (`load_rig` reads it back equal)."""
    return atomic_write_text(path, rig_yaml(rig, comment_lines))


__all__ = ["rig_yaml", "write_rig"]
