"""The README is a front door and the manual a site that builds: a broken link,
anchor or page in docs/ fails here, as `make docs` would."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def test_the_readme_is_short_and_starts_with_the_two_commands() -> None:
    text = README.read_text()
    assert len(text.splitlines()) <= 250
    blocks = re.findall(r"```sh\n(.*?)```", text, flags=re.S)
    assert [b.strip() for b in blocks[:2]] == ["make run", "make test"]


def test_every_link_of_the_readme_names_a_file_of_the_project() -> None:
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README.read_text())
    local = [t for t in targets if "://" not in t]
    assert local, "the README links to the manual"
    missing = [t for t in local if not (ROOT / t).exists()]
    assert missing == []


def test_every_page_the_readme_dropped_is_in_the_manual_menu() -> None:
    menu = (ROOT / "mkdocs.yml").read_text()
    pages = sorted(p.name for p in (ROOT / "docs").glob("*.md"))
    assert [p for p in pages if p not in menu] == []


def test_the_manual_builds_strict(tmp_path: Path) -> None:
    mkdocs = Path(sys.executable).parent / "mkdocs"
    run = subprocess.run(
        [str(mkdocs), "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "WARNING" not in run.stderr
    built = tmp_path / "site"
    assert (built / "index.html").exists()
    # The API reference is read from the docstrings, not written by hand.
    reference = (built / "reference" / "vocabulary" / "index.html").read_text()
    assert "planner.vocabulary" in reference and "class" in reference
