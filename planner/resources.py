"""Files that ship with the program: the scenarios and the ASP encodings.

Everything else finds them here, through `importlib.resources`, so a wheel
installed anywhere reads its own copies. The scenarios are the repository's
top-level `static/` folder, installed as the package `tandem_static`
(pyproject.toml maps the name to the folder); the encodings are package data
of `planner` (`planner/asp/*.lp`).
"""

from __future__ import annotations

from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

STATIC_PACKAGE = "tandem_static"


def _static_root() -> Path:
    try:
        root = resources.files(STATIC_PACKAGE)
    except ModuleNotFoundError:
        # A checkout run before any install (e.g. pytest's pythonpath "." in a
        # fresh clone): the folder the package is built from.
        root = Path(__file__).resolve().parents[1] / "static"
    if not isinstance(root, Path):
        # Wheels install unpacked; a zipped import has no folder to list or save beside.
        raise RuntimeError(f"{STATIC_PACKAGE} is not on the file system: {root}")
    return root


def scenario_dir() -> Path:
    """The folder of the shipped scenario files (`default.toml`, `paper/U10.toml`, ...)."""
    return _static_root() / "scenarios"


def scenario_path(name: str | Path) -> Path:
    """The shipped scenario `name`, relative to `scenario_dir()` (it may not exist)."""
    return scenario_dir() / name


def find_scenario(name: str | Path) -> Path:
    """`name` if that file exists, else the shipped scenario of that name, else `name`
    unchanged (so the error that follows names what the user typed)."""
    given = Path(name)
    if given.exists() or given.is_absolute():
        return given
    shipped = scenario_path(given)
    return shipped if shipped.is_file() else given


def encoding_dir() -> Traversable:
    """The folder of the ASP encodings, one `.lp` file per concern."""
    return resources.files("planner") / "asp"
