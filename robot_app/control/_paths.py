"""Where robot_app's own URDF files live, for editable and regular installs.

The URDFs are kept in the repository's top-level `urdf/` folder (see DESIGN.md). An
editable install or a source checkout finds them next to the package. `robot_app/urdf`
is a symlink to that folder, so a wheel that lists `urdf/*.urdf` in its package data
carries a copy and a regular install finds it there. `ROBOT_APP_URDF_DIR` overrides both.
"""

from __future__ import annotations

import os
from pathlib import Path

from robot_app.errors import InputError

URDF_DIR_ENV = "ROBOT_APP_URDF_DIR"


def urdf_search_dirs() -> tuple[Path, ...]:
    """Folders searched for robot_app's URDFs, in order."""
    package_dir = Path(__file__).resolve().parent.parent  # robot_app/
    dirs = []
    if os.environ.get(URDF_DIR_ENV):
        dirs.append(Path(os.environ[URDF_DIR_ENV]))
    dirs += [package_dir.parent / "urdf", package_dir / "urdf"]
    return tuple(dirs)


def urdf_path(file_name: str) -> Path:
    """Absolute path of one of robot_app's URDF files, e.g. 'pa10.urdf'.

    Raises:
        InputError: the file is in none of `urdf_search_dirs()`.
    """
    for folder in urdf_search_dirs():
        candidate = folder / file_name
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(d) for d in urdf_search_dirs())
    raise InputError(f"{file_name} not found in {searched}; set {URDF_DIR_ENV} to the folder holding it")


__all__ = ["URDF_DIR_ENV", "urdf_path", "urdf_search_dirs"]
