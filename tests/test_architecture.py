"""docs/architecture.md stays true: the modules it names exist, every module is named
there, and the import rules it states hold."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MAP = REPO / "docs" / "architecture.md"
PATH_PATTERN = re.compile(r"`((?:robot_app|scripts|configs|tests|urdf|docs)/[\w/.]+\.(?:py|yaml|urdf|md))`")

# what each package may import (docs/architecture.md, "Packages and what each may import")
BASE = {
    "errors",
    "arrays",
    "geometry",
    "config",
    "robot_description",
    "console",
    "input_files",
    "interrupts",
    "outputs",
    "resources",
}
ALLOWED = {
    "vision": BASE,
    "calibration": BASE | {"vision"},
    "control": BASE | {"vision"},
    "sim": BASE | {"vision", "calibration"},
    "experiments": BASE | {"vision", "calibration", "control", "sim"},
}


def _named_paths() -> set[str]:
    return set(PATH_PATTERN.findall(MAP.read_text()))


def _package_modules() -> set[str]:
    return {
        str(path.relative_to(REPO))
        for path in (REPO / "robot_app").rglob("*.py")
        if path.name != "__init__.py" or path.parent.name == "commands"
    }


def test_every_path_the_map_names_exists() -> None:
    missing = sorted(path for path in _named_paths() if not (REPO / path).exists())
    assert not missing, f"docs/architecture.md names files that do not exist: {missing}"


def test_every_module_is_on_the_map() -> None:
    absent = sorted(_package_modules() - _named_paths())
    assert not absent, f"modules missing from docs/architecture.md: {absent}"


def _imported_packages(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "robot_app" and len(parts) > 1:
                found.add(parts[1])
    return found


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_imports_follow_the_dependency_direction(package: str) -> None:
    allowed = ALLOWED[package] | {package}
    wrong = {
        str(path.relative_to(REPO)): sorted(_imported_packages(path) - allowed)
        for path in (REPO / "robot_app" / package).rglob("*.py")
        if _imported_packages(path) - allowed
    }
    assert not wrong, f"{package} imports outside {sorted(allowed)}: {wrong}"


def test_base_modules_import_only_base() -> None:
    for name in BASE:
        imported = _imported_packages(REPO / "robot_app" / f"{name}.py")
        assert imported <= BASE, f"robot_app/{name}.py imports {sorted(imported - BASE)}"
