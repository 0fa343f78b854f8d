"""Speech out: espeak-ng audio, the gTTS fallback offline, the cache, local playback."""

from __future__ import annotations

import time
import wave
from pathlib import Path

import pytest

from speech.devices import NoAudioDevice, play_local
from speech.languages import LANGUAGES, UnknownLanguage, language
from speech.synthesis import SynthesisError, cache_dir_default, forget_gtts_failure, synthesize

SENTENCES = {
    "en-us": [
        "Can you help me attach the leg?",
        "I will hold the top for you.",
        "Is the second leg attached now?",
        "Please pass me the screw.",
    ],
    "ko": ["다리를 붙이는 것을 도와줄 수 있어요?", "상판을 잡아 줄게요.", "네"],
}


def _no_empty_files(folder: Path) -> bool:
    return all(path.stat().st_size > 0 for path in folder.rglob("*") if path.is_file())


@pytest.mark.parametrize("code", sorted(SENTENCES))
def test_espeak_speaks_every_sentence_as_16k_mono_wav(code: str, tmp_path: Path) -> None:
    for text in SENTENCES[code]:
        utterance = synthesize(text, code, engine="espeak", cache_dir=tmp_path)
        assert utterance.engine == "espeak" and utterance.format == "wav"
        assert utterance.voice == language(code).espeak_voice
        with wave.open(str(utterance.path)) as reader:
            assert reader.getframerate() == 16_000
            assert reader.getnchannels() == 1
            assert reader.getsampwidth() == 2
            assert reader.getnframes() > 0
        # Plausible length: at least 0.2 s, at most 0.25 s per character.
        assert 0.2 <= utterance.duration_s <= 0.25 * len(text) + 1.0


def test_auto_falls_back_to_espeak_within_a_second_offline(tmp_path: Path) -> None:
    forget_gtts_failure()
    try:
        synthesize("Are you ready?", "en-us", engine="gtts", cache_dir=tmp_path / "probe")
    except SynthesisError as error:
        assert "\n" not in str(error) and str(error).startswith("gTTS failed")
    else:
        pytest.skip("Google's speech service answered: this machine is online")
    forget_gtts_failure()
    started = time.monotonic()
    utterance = synthesize("Can you help me?", "en-us", cache_dir=tmp_path)
    assert time.monotonic() - started < 1.0
    assert utterance.engine == "espeak" and utterance.path.stat().st_size > 44
    assert _no_empty_files(tmp_path)
    assert not list(tmp_path.rglob("*.mp3")) and not list(tmp_path.rglob("*.part"))


def test_cache_returns_the_same_file_the_second_time(tmp_path: Path) -> None:
    first = synthesize("Shall I hold it?", "en-us", engine="espeak", cache_dir=tmp_path)
    written = first.path.stat().st_mtime_ns
    second = synthesize("Shall I hold it?", "en-us", engine="espeak", cache_dir=tmp_path)
    assert second.path == first.path and second.path.stat().st_mtime_ns == written
    other = synthesize("Shall I hold it?", "ko", engine="espeak", cache_dir=tmp_path)
    assert other.path != first.path  # the voice is part of the key
    assert len(list(tmp_path.glob("*.wav"))) == 2


def test_cache_dir_follows_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TANDEM_CACHE_DIR", str(tmp_path))
    assert cache_dir_default() == tmp_path / "speech"
    utterance = synthesize("Hello", "en-us", engine="espeak")
    assert utterance.path.parent == tmp_path / "speech"


def test_unknown_language_and_empty_text_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(UnknownLanguage) as unknown:
        synthesize("Bonjour", "fr", cache_dir=tmp_path)
    assert "'fr'" in str(unknown.value) and "\n" not in str(unknown.value)
    assert all(code in str(unknown.value) for code in LANGUAGES)
    with pytest.raises(SynthesisError):
        synthesize("   ", "en-us", cache_dir=tmp_path)


def test_play_local_without_a_speaker_is_one_clear_error(tmp_path: Path) -> None:
    utterance = synthesize("Testing the speaker.", "en-us", engine="espeak", cache_dir=tmp_path)
    try:
        play_local(utterance)
    except NoAudioDevice as error:
        assert "\n" not in str(error) and "device" in str(error)
    else:
        pytest.skip("this machine has a speaker: the sentence was played")
