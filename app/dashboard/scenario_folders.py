"""The folders the dashboard's page may read scenarios from and save them to.

A page is anyone who reaches the port, so the names it sends are checked
before the file system is touched: a name is relative, made of plain parts,
ends in `.toml`, and once resolved (symlinks followed) stays inside one of the
allowed folders. The shipped scenarios and the folders named with
`--scenario-dir` are read-only; the user's folder (`scenarios/` in the data
directory) is where "Save as" writes, by plain file name only (letters, digits,
'-', '_' and '.'). Refusals are
one line that never quotes a file and never tells whether a file outside the
folders exists.
"""

from __future__ import annotations

import os
import re
import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from planner.resources import scenario_dir

USER_FOLDER = "scenarios"  # inside the data directory
RECORDINGS_FOLDER = "recordings"  # inside the data directory: videos and image folders
MAX_NAME_CHARS = 200  # a whole relative name; file systems allow 255 bytes per part
SUFFIX = ".toml"
# A name "Save as" writes: one word a shell, a URL and every file system take as it
# is (a space would be the first thing to break a later `tandem plan NAME`).
PLAIN_NAME = re.compile(r"\w[\w.-]*\.toml")
PLAIN_NAME_RULE = (
    "a file name may have letters, digits, '-', '_' and '.' only (no spaces), "
    "and ends in .toml, e.g. my-bench.toml"
)


class RefusedName(ValueError):
    """A scenario name the page may not use; `str()` is one line saying why."""


@dataclass(frozen=True)
class Folder:
    """One allowed folder; `label` is how the page names it."""

    path: Path
    label: str
    writable: bool = False


class ScenarioFolders:
    """The user's folder (writable, searched first), extra folders, the shipped ones."""

    def __init__(self, user_dir: Path, extra: Iterable[Path] = ()) -> None:
        folders = [Folder(user_dir, "user's", writable=True)]
        folders += [Folder(Path(p), f"'{Path(p).name}'") for p in extra]
        folders.append(Folder(scenario_dir(), "shipped"))
        self.folders: Sequence[Folder] = tuple(folders)
        self.user = folders[0]

    def names(self) -> list[str]:
        """Every readable scenario name, each once (the first folder wins), default first."""
        seen: dict[str, None] = {}
        for folder in self.folders:
            if not folder.path.is_dir():
                continue
            root = folder.path.resolve()
            for path in sorted(folder.path.rglob(f"*{SUFFIX}")):
                if not path.is_file() or not path.resolve().is_relative_to(root):
                    continue  # a symlink out of the folder is not offered
                seen.setdefault(path.relative_to(folder.path).as_posix(), None)
        return sorted(seen, key=lambda n: (n != "default.toml", n.count("/"), n))

    def find(self, name: str) -> Path:
        """The file a page's `name` stands for; raises `RefusedName`."""
        parts = _relative_parts(name)
        for folder in self.folders:
            candidate = folder.path.joinpath(*parts)
            # Checked before existence, so a link out of the folder tells nothing
            # about what it points at, or whether that exists.
            if not candidate.resolve().is_relative_to(folder.path.resolve()):
                raise RefusedName(f"{name}: leads out of the {folder.label} scenario folder")
            if not candidate.exists():
                continue
            if not candidate.is_file():
                raise RefusedName(f"{name}: not a file")
            return candidate
        raise RefusedName(f"{name}: no such scenario in the scenario folders")

    def name_of(self, path: Path) -> str | None:
        """The name the page offers for the file at `path`; None if no folder gives
        that name to it (outside the folders, or behind the same name in a folder
        searched before)."""
        resolved = path.resolve()
        for folder in self.folders:
            root = folder.path.resolve()
            if not resolved.is_relative_to(root):
                continue
            name = resolved.relative_to(root).as_posix()
            try:
                return name if self.find(name).resolve() == resolved else None
            except RefusedName:
                return None
        return None

    def save_path(self, name: str) -> Path:
        """Where "Save as" `name` writes (a new file in the user's folder); raises `RefusedName`."""
        plain = name.strip()
        if plain and not plain.endswith(SUFFIX) and "." not in plain:
            plain += SUFFIX  # "my-bench" means my-bench.toml
        parts = _relative_parts(plain)
        if len(parts) != 1:
            raise RefusedName(f"{name}: give a plain file name, without folders")
        if not PLAIN_NAME.fullmatch(parts[0]):
            raise RefusedName(f"{plain}: {PLAIN_NAME_RULE}")
        try:
            self.find(plain)
        except RefusedName:
            pass
        else:
            raise RefusedName(f"{plain}: a scenario of that name exists; choose a new name")
        return self.user.path / parts[0]

    def save(self, text: str, name: str) -> Path:
        """Writes `text` as a new file `name` in the user's folder; its path."""
        out = self.save_path(name)
        out.parent.mkdir(parents=True, exist_ok=True)
        # O_EXCL: never replace a file; O_NOFOLLOW: never write through a symlink
        # planted under that name after the check.
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
        try:
            fd = os.open(out, flags, 0o644)
        except FileExistsError:
            raise RefusedName(f"{out.name}: exists already; choose a new name") from None
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        return out


def find_recording(root: Path, name: str) -> Path:
    """A video file or image folder the page named, inside `root` only; `RefusedName`.

    The camera panel may read what is there and show it, so a page must not
    name anything else on the server.
    """
    parts = _relative_parts(name, suffix=None)
    candidate = root.joinpath(*parts)
    if not candidate.resolve().is_relative_to(root.resolve()):
        raise RefusedName(f"{name}: leads out of the recordings folder")
    if not candidate.exists():
        raise RefusedName(f"{name}: no such video or image folder in the recordings folder")
    return candidate


def _relative_parts(name: str, suffix: str | None = SUFFIX) -> tuple[str, ...]:
    """The parts of a relative name (ending in `suffix` unless None), or `RefusedName`."""
    if not name.strip():
        raise RefusedName("give a scenario name, e.g. default.toml")
    shown = name if len(name) <= 60 else name[:57] + "..."
    if len(name) > MAX_NAME_CHARS:
        raise RefusedName(f"{shown}: name too long (at most {MAX_NAME_CHARS} characters)")
    if any(unicodedata.category(c)[0] == "C" for c in name):
        raise RefusedName(f"{shown!r}: control characters are not allowed in a name")
    if "\\" in name:
        raise RefusedName(f"{shown}: use / between folders")
    if name.startswith(("/", "~")):
        raise RefusedName(f"{shown}: give a name inside the scenario folders, not a path")
    path = PurePosixPath(name)
    if any(part in ("..", ".") for part in name.split("/")) or not path.parts:
        raise RefusedName(f"{shown}: '.' and '..' are not allowed in a name")
    if any(part == "" for part in name.split("/")):
        raise RefusedName(f"{shown}: empty folder name")
    if any(part.startswith(".") for part in path.parts):
        raise RefusedName(f"{shown}: hidden files are not scenarios")
    if suffix is not None and path.suffix != suffix:
        raise RefusedName(f"{shown}: a scenario file name ends in {suffix}")
    return path.parts
