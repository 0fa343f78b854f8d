"""`tandem execute --responses voice:SOURCE`: the Korean scenario answered by voice.

The 20-seed loop runs `tandem execute` in this process (`app.cli.main.main`,
the CLI's own code path, so the Korean model loads once); one more run is a
real subprocess. The stored sessions must say, for every question, whether the
voice or the fallback answered, with the words heard and what the simulated
human really said.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from pathlib import Path

import pytest

from app.cli.main import main
from app.execution.events import ExecutionEvent
from app.sessions.store import SessionStore
from planner.plan.model import Plan
from tests.plan_fixtures import KOREAN_DEFAULT, korean_plan, tandem
from tests.plan_paths import is_plan_path

SEEDS = range(20)


def _questions(plan: Plan, events: list[ExecutionEvent]) -> list[ExecutionEvent]:
    return [e for e in events if e.kind == "communication" and plan.nodes[e.node].outcomes]


def _check_session(plan: Plan, store: SessionStore, session_id: int) -> Counter[str]:
    """Checks one stored session; counts its questions by who answered."""
    record = store.get(session_id)
    assert record.result == "goal"
    events = store.events(session_id)
    assert is_plan_path(plan, store.path(session_id))
    counts: Counter[str] = Counter()
    for event in events:
        if event.kind != "communication":
            continue
        assert event.evidence is not None, event
        # Every sentence was spoken, by espeak-ng here (offline), and kept: by the
        # narrator, or (a question) by the voice that then listened.
        spoken, hearing = event.evidence.spoken, event.evidence.voice
        if spoken is not None:
            assert spoken.engine == "espeak" and spoken.said
        else:
            assert hearing is not None and hearing.engine == "espeak", event
    for event in _questions(plan, events):
        assert event.evidence is not None
        hearing, truth = event.evidence.voice, event.evidence.truth
        assert hearing is not None and hearing.tries >= 1 and hearing.engine == "espeak"
        assert truth is not None and truth.label in ("yes", "no") and truth.said
        if event.source == "voice":
            assert hearing.answered_by == "voice" and hearing.meaning == event.outcome
            assert 1 <= hearing.tries <= 2
            # The dangerous case would be a wrong answer taken: the truth says none was.
            assert truth.label == event.outcome, hearing
            counts["voice"] += 1
        else:
            assert hearing.answered_by == "fallback" and event.source == "random"
            assert hearing.tries == 2 and hearing.meaning is None
            counts["fallback"] += 1
    return counts


def test_korean_scenario_by_voice_for_20_seeds_in_process(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = korean_plan()
    data = tmp_path / "data"
    for seed in SEEDS:
        code = main([
            "execute", str(KOREAN_DEFAULT), "--responses", "voice:sim", "--human", "random",
            "--seed", str(seed), "--data-dir", str(data),
        ])  # fmt: skip
        assert code == 0, f"seed {seed}"
    log = capsys.readouterr().err
    # The log shows each line as it is spoken, and what was heard.
    assert log.count("robot says (espeak):") >= len(SEEDS) and "heard '" in log
    totals: Counter[str] = Counter()
    with SessionStore(data) as store:
        sessions = store.list_sessions()
        assert len(sessions) == len(SEEDS)
        for session in sessions:
            assert session.note is not None and session.note.startswith("seed ")
            totals += _check_session(plan, store, session.id)
    print(f"\n{len(SEEDS)} seeds: {totals['voice']} questions by voice, "
          f"{totals['fallback']} by the fallback")  # fmt: skip
    # Measured: 36 by voice, 0 by the fallback.
    assert totals["voice"] >= 0.85 * (totals["voice"] + totals["fallback"])


def test_a_real_cli_run_and_its_exported_session(tmp_path: Path) -> None:
    env = {**os.environ, "TANDEM_DATA_DIR": str(tmp_path)}
    done = tandem(
        "execute", str(KOREAN_DEFAULT), "--responses", "voice:sim", "--human", "random",
        "--seed", "4", env=env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1].split()[2] == "goal"
    assert 'robot says (espeak): "' in done.stderr
    session = int(done.stdout.split()[1])
    exported = tandem("sessions", "export", str(session), env=env)
    assert exported.returncode == 0, exported.stderr
    events = json.loads(exported.stdout)["events"]
    asked = [e for e in events if e["evidence"] and "voice" in e["evidence"]]
    assert asked and all(e["evidence"]["truth"]["said"] for e in asked)
    assert all(e["evidence"]["version"] == 2 for e in asked)
    assert all(e["source"] in ("voice", "random") for e in asked)
    # The listing says, under each question, what was heard and really said.
    shown = tandem("sessions", "show", str(session), env=env)
    assert shown.returncode == 0, shown.stderr
    heard = [line for line in shown.stdout.splitlines() if "answered by" in line]
    assert len(heard) == len(asked)
    assert all("the simulated human said '" in line and "spoken by espeak" in line
               for line in heard)  # fmt: skip


def test_a_scripted_human_answers_as_scripted(tmp_path: Path) -> None:
    script = tmp_path / "answers.txt"
    script.write_text("no  # confirmAttach: not attaching\nno\n", encoding="utf-8")
    data = tmp_path / "data"
    code = main([
        "execute", str(KOREAN_DEFAULT), "--responses", "voice:sim", "--human",
        f"scripted:{script}", "--seed", "1", "--data-dir", str(data),
    ])  # fmt: skip
    assert code == 0
    with SessionStore(data) as store:
        (session,) = store.list_sessions()
        truths = [
            e.evidence.truth.label
            for e in store.events(session.id)
            if e.evidence is not None and e.evidence.truth is not None
        ]
    assert truths[:2] == ["no", "no"]


def _one_line(done_code: int, err: str) -> str:
    assert done_code == 2
    lines = [line for line in err.strip().splitlines() if not line.startswith("seed ")]
    assert len(lines) == 1, err
    return lines[0]


def test_no_model_no_microphone_no_folder_are_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    base = ["execute", str(KOREAN_DEFAULT), "--data-dir", str(tmp_path)]
    code = main([*base, "--responses", "voice:sim", "--vosk-model", str(tmp_path)])
    assert "not a vosk model directory" in _one_line(code, capsys.readouterr().err)
    code = main([*base, "--responses", f"voice:{tmp_path / 'missing'}"])
    assert "no such folder" in _one_line(code, capsys.readouterr().err)
    code = main([*base, "--responses", "voice:sim", "--human", "scripted:"])
    assert "--human" in _one_line(code, capsys.readouterr().err)
    try:
        import sounddevice  # type: ignore[import-untyped]

        sounddevice.query_devices(kind="input")
    except Exception:  # no PortAudio or no input device: the case to test
        code = main([*base, "--responses", "voice:mic"])
        assert "microphone" in _one_line(code, capsys.readouterr().err)
    # English: heard offline by pocketsphinx's bundled model, nothing downloaded.
    monkeypatch.delenv("TANDEM_VOSK_MODEL", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    code = main([*base, "--responses", "voice:sim", "--language", "en-us", "--seed", "3"])
    assert code == 0 and "heard '" in capsys.readouterr().err


def test_a_wav_folder_answers_then_runs_dry_and_the_fallback_answers(tmp_path: Path) -> None:
    from speech.audio import encode_wav
    from speech.sources import SimulatedVoice

    answers = tmp_path / "answers"
    answers.mkdir()
    clip = SimulatedVoice("ko").render("아니요")
    (answers / "01.wav").write_bytes(encode_wav(clip.samples, clip.rate))
    data = tmp_path / "data"
    code = main([
        "execute", str(KOREAN_DEFAULT), "--responses", f"voice:{answers}", "--seed", "5",
        "--data-dir", str(data),
    ])  # fmt: skip
    assert code == 0
    plan = korean_plan()
    with SessionStore(data) as store:
        (session,) = store.list_sessions()
        asked = _questions(plan, store.events(session.id))
    assert asked
    first, rest = asked[0], asked[1:]
    assert rest
    assert first.evidence is not None
    assert (first.source, first.outcome) == ("voice", "no")
    assert first.evidence.voice is not None
    assert str(first.evidence.voice.attempts[0].audio).endswith("01.wav")
    # The folder has no more answers: each later question is refused twice, then the
    # seeded fallback answers, and the session says so.
    for event in rest:
        assert event.evidence is not None and event.source == "random"
        hearing = event.evidence.voice
        assert hearing is not None and hearing.answered_by == "fallback" and hearing.tries == 2
        assert hearing.fallback == "random"
        assert [a.reason for a in hearing.attempts] == ["silence", "silence"]
        assert event.evidence.truth is None  # nobody simulated: no truth to tell


def test_speak_local_without_speakers_says_so_once_and_goes_on(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from speech.devices import NoAudioDevice, require_device

    try:
        require_device("output")
    except NoAudioDevice:
        pass
    else:
        pytest.skip("this machine has speakers: the lines were played")
    code = main([
        "execute", str(KOREAN_DEFAULT), "--responses", "voice:sim", "--seed", "2",
        "--speak", "local", "--data-dir", str(tmp_path),
    ])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 0 and err.count("(not played: ") == 1
    assert err.count("robot says (espeak):") >= 3
