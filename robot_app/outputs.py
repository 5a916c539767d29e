"""Output paths: checked before the work, written atomically, nothing left behind on failure.

Every command that writes checks each output path first (`check_output_file`,
`check_output_folder`): the right kind (a file name is not a folder, a results folder is
not a file), a folder that can really be written (tried with a probe file, so read-only
mounts, permissions and ACLs all count), and no existing results folder unless the
command's `--force` or resume rule allows it. Nothing is created by a check.

Files are then written through `atomic_path` (or `atomic_write_text`): the data goes to
a hidden temporary file in the same folder, which replaces the target only when it is
complete, so an error, an interrupt or a full disk never leaves a half file.
`output_folder` creates a results folder and removes it again if the work fails before
anything was written into it.
"""

from __future__ import annotations

import csv
import io
import os
import secrets
import shutil
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robot_app.errors import OutputError


def _nearest_existing(path: Path) -> Path:
    """`path` or its nearest ancestor that exists (the current folder's for a relative path)."""
    candidate = path
    while not candidate.exists() and not candidate.is_symlink():
        parent = candidate.parent
        if parent == candidate:
            break
        candidate = parent
    return candidate


def _check_writable_folder(folder: Path, target: Path, key: str) -> None:
    """Writes and removes a probe file in `folder`; OutputError naming `target` if that fails."""
    if not folder.is_dir():
        raise OutputError(
            f"{key} {target}: {folder} is a file, not a folder",
            path=target,
            key=key,
            value=str(target),
            expected="a path whose parents are folders",
        )
    probe = folder / f".robot_app-probe-{secrets.token_hex(4)}"
    try:
        with probe.open("xb"):
            pass
        probe.unlink()
    except OSError as err:
        raise OutputError(
            f"{key} {target}: cannot write in {folder} ({err.strerror or err})",
            path=target,
            key=key,
            value=str(target),
            expected="a writable location",
        ) from err


def _either(names: tuple[str, ...]) -> str:
    """'.npz', '.yaml or .yml', '.png, .jpg or .bmp'."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"


def check_output_file(
    path: str | Path,
    *,
    key: str,
    suffixes: tuple[str, ...] = (),
    create_parents: bool = True,
) -> Path:
    """Checks that `path` can be written as a file; creates nothing.

    Args:
        path: the file to write (an existing file is replaced).
        key: the option that named it (`--out`, `--video`), for the message.
        suffixes: accepted file name endings (lower case, with the dot); empty: any.
        create_parents: missing parent folders will be created (else they must exist).

    Raises:
        OutputError: a folder, a device or other non-regular file, a wrong suffix, a
            missing parent folder (without `create_parents`) or an unwritable location.
    """
    target = Path(path)
    if target.is_dir():
        raise OutputError(
            f"{key} {target} is a folder; give a file name"
            + (f" ending in {_either(suffixes)}" if suffixes else ""),
            path=target,
            key=key,
            value=str(target),
            expected="a file name",
        )
    if suffixes and target.suffix.lower() not in suffixes:
        raise OutputError(
            f"{key} {target}: must name a {_either(suffixes)} file",
            path=target,
            key=key,
            value=str(target),
            expected=f"a file name ending in {_either(suffixes)}",
        )
    if target.exists() and not stat.S_ISREG(target.stat().st_mode):
        raise OutputError(
            f"{key} {target} is not a regular file (a device, pipe or socket); give a file name",
            path=target,
            key=key,
            value=str(target),
            expected="a regular file name",
        )
    parent = target.parent
    if not create_parents and not parent.is_dir():
        what = "is a file, not a folder" if parent.exists() else "does not exist"
        raise OutputError(
            f"{key} {target}: cannot write there, folder {parent} {what}",
            path=target,
            key=key,
            value=str(target),
            expected="a file in an existing folder",
        )
    _check_writable_folder(_nearest_existing(parent), target, key)
    return target


def folder_entries(path: Path) -> list[str]:
    """Names in an existing folder, sorted (empty if it is not a folder)."""
    try:
        return sorted(entry.name for entry in path.iterdir())
    except OSError:
        return []


def check_output_folder(path: str | Path, *, key: str, force: bool = False, resumable: bool = False) -> Path:
    """Checks that `path` can be a results folder; creates nothing.

    Args:
        path: the folder (created later by `output_folder`).
        key: the option that named it (`--out`), for the message.
        force: an existing folder with files in it may be written into.
        resumable: the caller has checked that the folder holds a run it resumes.

    Raises:
        OutputError: `path` is a file, holds files already (without `force` or
            `resumable`), or its location cannot be written.
    """
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(
            f"{key} {target} is a file; give a folder for the results",
            path=target,
            key=key,
            value=str(target),
            expected="a new or empty folder",
        )
    entries = folder_entries(target)
    if entries and not (force or resumable):
        shown = ", ".join(entries[:4]) + (", ..." if len(entries) > 4 else "")
        raise OutputError(
            f"{key} {target} already holds files ({shown}); choose a new folder, "
            "or pass --force to write this run's files into it",
            path=target,
            key=key,
            value=str(target),
            expected="a new or empty folder (or --force)",
        )
    _check_writable_folder(_nearest_existing(target), target, key)
    return target


def unique_folder(path: str | Path) -> Path:
    """`path`, or `path-2`, `path-3`, ... if it exists (for default, time-stamped folders)."""
    base = Path(path)
    candidate, number = base, 1
    while candidate.exists():
        number += 1
        candidate = base.with_name(f"{base.name}-{number}")
    return candidate


def _missing_folders(folder: Path) -> list[Path]:
    """Folders from the nearest existing ancestor of `folder` down to it that do not exist yet."""
    missing = []
    candidate = folder
    while not candidate.exists():
        missing.append(candidate)
        if candidate.parent == candidate:
            break
        candidate = candidate.parent
    return missing  # deepest first


def _remove_empty(folders: list[Path]) -> None:
    for folder in folders:  # deepest first
        try:
            folder.rmdir()
        except OSError:
            return  # not empty (or gone): keep it and its parents


@contextmanager
def output_folder(path: str | Path) -> Iterator[Path]:
    """Creates `path` (and missing parents) for the block; removes those still empty if it fails."""
    folder = Path(path)
    created = _missing_folders(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        _remove_empty(created)
        raise OutputError(f"cannot create {folder}: {err.strerror or err}", path=folder) from err
    try:
        yield folder
    except BaseException:
        _remove_empty(created)
        raise


@contextmanager
def staged_folder(path: str | Path) -> Iterator[Path]:
    """Yields a hidden temporary folder; its files move into `path` when the block succeeds.

    For writers that fill a folder by themselves (several pictures): each file arrives
    whole (`os.replace`), and a failure leaves neither the new files nor new folders.
    """
    target = Path(path)
    created = _missing_folders(target)
    stage = target.parent / f".{target.name}-{secrets.token_hex(4)}.tmp"
    try:
        stage.mkdir(parents=True)
        yield stage
        target.mkdir(parents=True, exist_ok=True)
        for entry in sorted(stage.iterdir()):
            if entry.is_file():
                entry.chmod(_file_mode())
            os.replace(entry, target / entry.name)
        stage.rmdir()
    except BaseException as err:
        shutil.rmtree(stage, ignore_errors=True)
        _remove_empty(created)
        if isinstance(err, OSError):
            raise OutputError(f"cannot write into {target}: {err.strerror or err}", path=target) from err
        raise


def _file_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yields a temporary path next to `path`; it replaces `path` when the block succeeds.

    For writers that take a file name (cv2.imwrite, matplotlib, video writers): the
    temporary keeps the target's suffix, so the format is inferred the same. If the
    block raises (or is interrupted), the temporary is removed and `path` is untouched;
    if the block deletes the temporary itself, nothing is renamed. Missing parent
    folders are created, and removed again if nothing ends up in them.

    Raises:
        OutputError: the file cannot be written (an OSError inside the block or on rename).
    """
    target = Path(path)
    created = _missing_folders(target.parent)
    temporary = target.with_name(f".{target.stem}-{secrets.token_hex(4)}.tmp{target.suffix}")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        yield temporary
        if temporary.exists():
            temporary.chmod(_file_mode())
            os.replace(temporary, target)
    except OSError as err:
        temporary.unlink(missing_ok=True)
        _remove_empty(created)
        raise OutputError(f"cannot write {target}: {err.strerror or err}", path=target) from err
    except BaseException:
        temporary.unlink(missing_ok=True)
        _remove_empty(created)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Writes `data` to `path` atomically (see `atomic_path`)."""
    with atomic_path(path) as temporary:
        temporary.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Writes `text` (UTF-8) to `path` atomically (see `atomic_path`)."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_csv(path: str | Path, rows: list[dict[str, object]]) -> Path:
    """Writes `rows` as a CSV table (header from the first row's keys) to `path` atomically;
    no rows: an empty file."""
    buffer = io.StringIO(newline="")
    if rows:
        writer = csv.DictWriter(buffer, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return atomic_write_text(path, buffer.getvalue())


def atomic_write_image(path: str | Path, image: npt.NDArray[np.uint8]) -> Path:
    """Encodes an image by its file suffix (default PNG) and writes it atomically.

    Raises:
        OutputError: OpenCV cannot encode an image of that suffix.
    """
    import cv2  # here, not at the top: the base modules load without OpenCV

    file = Path(path)
    ok, encoded = cv2.imencode(file.suffix or ".png", image)
    if not ok:
        raise OutputError(f"cannot encode an image as {file.suffix or '.png'}", path=file)
    return atomic_write_bytes(file, encoded.tobytes())


__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_csv",
    "atomic_write_image",
    "atomic_write_text",
    "check_output_file",
    "check_output_folder",
    "folder_entries",
    "output_folder",
    "staged_folder",
    "unique_folder",
]
