"""`tandem say` and `tandem listen` on the real espeak-ng and the real Korean model
(English: tests/test_speech_english_cli.py)."""

from __future__ import annotations

import time
import wave
from pathlib import Path

import numpy as np
import pytest

from app.cli.main import main
from speech.audio import RATE, encode_wav
from speech.synthesis import forget_gtts_failure
from tests.plan_fixtures import default_plan


def test_say_writes_espeak_audio_for_every_communication_of_the_default_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = default_plan()
    sentences = sorted({n.say for n in plan.nodes.values() if n.kind == "communication" and n.say})
    assert len(sentences) >= 5
    for index, text in enumerate(sentences):
        target = tmp_path / f"{index}.wav"
        assert main(["say", text, "--engine", "espeak", "-o", str(target)]) == 0
        with wave.open(str(target)) as audio:
            assert audio.getframerate() == RATE and audio.getnframes() > 0.5 * RATE, text
    out = capsys.readouterr().out
    assert out.count("espeak (en-us)") == len(sentences)


def test_say_with_gtts_unreachable_falls_back_within_a_second(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TANDEM_CACHE_DIR", str(tmp_path / "cache"))  # nothing cached yet
    forget_gtts_failure()
    target = tmp_path / "out" / "hello.wav"
    started = time.monotonic()
    code = main(["say", "Shall I attach the foot for you?", "--engine", "gtts", "-o", str(target)])
    elapsed = time.monotonic() - started
    captured = capsys.readouterr()
    assert code == 0
    if target.with_suffix(".mp3").exists():
        pytest.skip("Google's speech service answered: this machine is online")
    assert elapsed < 1.0
    (warning,) = captured.err.strip().splitlines()  # one line, no traceback
    assert warning.startswith("gTTS failed") and "espeak-ng speaks instead" in warning
    assert target.stat().st_size > 44 and "espeak" in captured.out
    files = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert files and all(p.stat().st_size > 0 for p in files)
    assert not [p for p in files if p.suffix in (".mp3", ".part")]


def test_listen_prints_words_confidence_and_meaning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    yes = tmp_path / "yes.wav"
    assert main(["say", "네", "--language", "ko", "--engine", "espeak", "-o", str(yes)]) == 0
    capsys.readouterr()
    assert main(["listen", "--wav", str(yes), "--language", "ko"]) == 0
    assert capsys.readouterr().out.strip() == "heard '네' confidence 1.00: yes"
    # Other words: the grammar is the words given.
    no = tmp_path / "no.wav"
    assert main(["say", "됐어", "--language", "ko", "--engine", "espeak", "-o", str(no)]) == 0
    capsys.readouterr()
    assert main(["listen", "--wav", str(no), "--language", "ko", "--words", "맞아+네,됐어"]) == 0
    assert capsys.readouterr().out.strip().endswith(": no")
    quiet = tmp_path / "quiet.wav"
    quiet.write_bytes(encode_wav(np.zeros(RATE, dtype=np.int16), RATE))
    assert main(["listen", "--wav", str(quiet)]) == 1
    assert capsys.readouterr().out.strip() == "refused (silence): heard '-' confidence 0.00"


def test_listen_errors_are_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["listen", "--wav", str(tmp_path / "none.wav")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["listen", "--wav", str(tmp_path), "--vosk-model", str(tmp_path)]) == 2
    assert "not a vosk model directory" in capsys.readouterr().err
    assert main(["listen", "--words", "네"]) == 2
    assert "expected YES,NO" in capsys.readouterr().err
