"""The page reads and writes scenarios only inside the allowed folders.

Every tricky name is refused (or confined to the user's folder) with one line
that quotes no file and does not tell whether a file outside exists.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from app.dashboard import scenario_edit
from app.dashboard.scenario_folders import RefusedName, ScenarioFolders, find_recording
from planner.resources import scenario_path

SECRET = "s3cr3t-token-ABC123"


@pytest.fixture
def layout(tmp_path: Path) -> tuple[ScenarioFolders, Path]:
    """A user folder, an extra lab folder, and secrets outside both."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.toml").write_text(f'name = "{SECRET}"\n')
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "bench.toml").write_text(scenario_path("default.toml").read_text())
    (lab / "link-out.toml").symlink_to(outside / "secret.toml")
    (lab / "dir-out").symlink_to(outside, target_is_directory=True)
    (lab / "dangling.toml").symlink_to(outside / "nothing-here.toml")
    user = tmp_path / "data" / "scenarios"
    return ScenarioFolders(user, [lab]), outside


READ_REFUSED = [
    ("", "give a scenario name"),
    ("   ", "give a scenario name"),
    ("/etc/passwd", "not a path"),
    ("{outside}/secret.toml", "not a path"),
    ("~/secret.toml", "not a path"),
    ("~root/.bashrc", "not a path"),
    ("../outside/secret.toml", "'.' and '..'"),
    ("paper/../../outside/secret.toml", "'.' and '..'"),
    ("./default.toml", "'.' and '..'"),
    ("link-out.toml", "leads out"),
    ("dir-out/secret.toml", "leads out"),
    ("dangling.toml", "leads out"),
    ("paper//U10.toml", "empty folder name"),
    ("x" * 300 + ".toml", "too long"),
    ("secret.txt", "ends in .toml"),
    ("default", "ends in .toml"),
    (".hidden.toml", "hidden"),
    ("bench.toml\x00.txt", "control characters"),
    ("bench\n.toml", "control characters"),
    ("..\\outside\\secret.toml", "use /"),
    ("missing.toml", "no such scenario"),
]


@pytest.mark.parametrize(("name", "why"), READ_REFUSED)
def test_open_refuses_tricky_names_in_one_line(
    layout: tuple[ScenarioFolders, Path], name: str, why: str
) -> None:
    folders, outside = layout
    name = name.replace("{outside}", str(outside))
    loaded = scenario_edit.load_named(folders, name)
    assert loaded.scenario is None and loaded.text == ""
    assert why in loaded.error, loaded.error
    assert "\n" not in loaded.error and SECRET not in loaded.error
    assert len(loaded.error) < 200


def test_a_missing_file_outside_and_an_existing_one_look_the_same(
    layout: tuple[ScenarioFolders, Path],
) -> None:
    folders, outside = layout
    there = scenario_edit.load_named(folders, "dir-out/secret.toml").error
    absent = scenario_edit.load_named(folders, "dir-out/absent.toml").error
    assert there.replace("secret", "X") == absent.replace("absent", "X")


def test_open_reads_the_allowed_folders(layout: tuple[ScenarioFolders, Path]) -> None:
    folders, _ = layout
    for name in ("bench.toml", "default.toml", "paper/U10.toml"):
        loaded = scenario_edit.load_named(folders, name)
        assert loaded.scenario is not None, loaded.error
        assert loaded.source == name  # the page sees the name, not the server's path
    names = folders.names()
    assert names[0] == "default.toml" and "bench.toml" in names and "paper/U10.toml" in names
    assert "link-out.toml" not in names and not any(n.startswith("dir-out") for n in names)


SAVE_REFUSED = [
    ("/tmp/evil.toml", "not a path"),
    ("../evil.toml", "'.' and '..'"),
    ("sub/evil.toml", "plain file name"),
    ("~/evil.toml", "not a path"),
    ("", "give a scenario name"),
    ("evil.sh", "ends in .toml"),
    ("e" * 300, "too long"),
    ("default.toml", "exists"),  # would shadow the shipped one
    ("bench.toml", "exists"),
]


@pytest.mark.parametrize(("name", "why"), SAVE_REFUSED)
def test_save_refuses_tricky_names(
    layout: tuple[ScenarioFolders, Path], tmp_path: Path, name: str, why: str
) -> None:
    folders, _ = layout
    before = sorted(p for p in tmp_path.rglob("*") if not p.is_symlink())
    with pytest.raises(RefusedName, match=why) as refused:
        folders.save('name = "x"\n', name)
    assert "\n" not in str(refused.value)
    assert sorted(p for p in tmp_path.rglob("*") if not p.is_symlink()) == before


def test_save_writes_a_new_file_in_the_user_folder_only(
    layout: tuple[ScenarioFolders, Path],
) -> None:
    folders, _ = layout
    text = scenario_path("default.toml").read_text()
    out = folders.save(text, "my-bench")  # the suffix is added
    assert out == folders.user.path / "my-bench.toml" and out.read_text() == text
    assert scenario_edit.load_named(folders, "my-bench.toml").scenario is not None
    with pytest.raises(RefusedName, match="exists"):
        folders.save(text, "my-bench.toml")


def test_save_never_writes_through_a_planted_symlink(
    layout: tuple[ScenarioFolders, Path],
) -> None:
    folders, outside = layout
    folders.user.path.mkdir(parents=True)
    target = outside / "planted.toml"
    (folders.user.path / "trap.toml").symlink_to(target)
    with pytest.raises(RefusedName):
        folders.save('name = "x"\n', "trap.toml")
    assert not target.exists()


def test_scenario_errors_on_the_page_quote_no_values(tmp_path: Path) -> None:
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "leaky.toml").write_text(f'name = 7\nsecret = "{SECRET}"\n[preferences]\nsafety = 3\n')
    folders = ScenarioFolders(tmp_path / "user", [lab])
    error = scenario_edit.load_named(folders, "leaky.toml").error
    assert error.startswith("leaky.toml: ") and SECRET not in error
    assert str(tmp_path) not in error  # nor the server's folders
    assert os.sep not in error.split(":")[0]


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("/etc", "not a path"),
        ("../outside", "'.' and '..'"),
        ("~/video.avi", "not a path"),
        ("out/secret.toml", "leads out"),
        ("missing.avi", "no such video"),
        ("", "give a scenario name"),
    ],
)
def test_the_camera_reads_only_the_recordings_folder(
    layout: tuple[ScenarioFolders, Path], tmp_path: Path, name: str, why: str
) -> None:
    _, outside = layout
    recordings = tmp_path / "data" / "recordings"
    (recordings / "bench-frames").mkdir(parents=True)
    (recordings / "out").symlink_to(outside, target_is_directory=True)
    with pytest.raises(RefusedName, match=why):
        find_recording(recordings, name)
    assert find_recording(recordings, "bench-frames") == recordings / "bench-frames"
