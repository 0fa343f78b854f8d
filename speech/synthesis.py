"""Text to speech: gTTS when Google's service answers, else Debian's espeak-ng.

`synthesize(text, language)` returns an `Utterance`: a cached audio file, the
engine that made it, the voice and the duration. Files are cached on disk
keyed by (text, voice, engine) and written atomically (temporary file, then
rename), so a failed or interrupted synthesis never leaves a partial or empty
file behind.

gTTS gives MP3, and it is kept as MP3: browsers play it directly (the
dashboard sends audio to the page), and turning it into WAV here would need an
MP3 decoder the project does not have (no ffmpeg, no decoder in numpy). Its
duration is computed from the MP3 frame header's bit rate (gTTS writes
constant-bit-rate MP3). espeak-ng output is WAV, resampled to 16 kHz mono, the
format the recogniser and the simulated voice share.

Offline, gTTS fails within milliseconds (the connection is refused); after a
failure it is not asked again for `GTTS_RETRY_S` seconds, so a dialogue does
not pay the timeout on every sentence when the service is slow to answer.
"""

from __future__ import annotations

import hashlib
import io
import os
import subprocess
import time
import wave
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from speech.audio import RATE, Samples, decode_wav, encode_wav, resample, write_atomically
from speech.languages import Language, language

Engine = Literal["auto", "gtts", "espeak"]

GTTS_TIMEOUT_S = 0.8
GTTS_RETRY_S = 60.0
_gtts_failed_at: float | None = None


class SynthesisError(RuntimeError):
    """No engine could speak the text (the message says why, in one line)."""


@dataclass(frozen=True)
class Utterance:
    text: str
    path: Path
    engine: Literal["gtts", "espeak"]
    voice: str
    duration_s: float

    @property
    def format(self) -> Literal["wav", "mp3"]:
        return "mp3" if self.path.suffix == ".mp3" else "wav"


def cache_dir_default() -> Path:
    """`$TANDEM_CACHE_DIR/speech`, else `~/.cache/tandem/speech`."""
    root = os.environ.get("TANDEM_CACHE_DIR")
    base = Path(root) if root else Path.home() / ".cache" / "tandem"
    return base / "speech"


def _cache_path(cache_dir: Path, text: str, voice: str, engine: str, suffix: str) -> Path:
    key = hashlib.sha256(f"{engine}\0{voice}\0{text}".encode()).hexdigest()[:32]
    return cache_dir / f"{engine}-{key}{suffix}"


def espeak_samples(text: str, voice: str, speed: int = 175, pitch: int = 50) -> Samples:
    """16 kHz mono samples of espeak-ng speaking `text` (voice may carry a "+variant")."""
    try:
        done = subprocess.run(
            ["espeak-ng", "-v", voice, "-s", str(speed), "-p", str(pitch), "--stdout", text],
            capture_output=True,
            timeout=30,
            check=False,
        )
    except FileNotFoundError:
        raise SynthesisError("espeak-ng is not installed (Debian: apt install espeak-ng)") from None
    if done.returncode != 0 or not done.stdout:
        reason = done.stderr.decode(errors="replace").strip().splitlines()
        raise SynthesisError(f"espeak-ng failed: {reason[-1] if reason else 'no audio'}")
    samples, rate = decode_wav(done.stdout)
    return resample(samples, rate, RATE)


def _wav_duration(path: Path) -> float:
    with wave.open(str(path)) as reader:
        return float(reader.getnframes()) / float(reader.getframerate())


_MPEG1_L3_KBPS = (0, 32, 40, 48, 56, 64, 80, 96, 112, 128, 160, 192, 224, 256, 320)
_MPEG2_L3_KBPS = (0, 8, 16, 24, 32, 40, 48, 56, 64, 80, 96, 112, 128, 144, 160)


def mp3_duration(data: bytes) -> float:
    """Duration of constant-bit-rate MP3 bytes, from the first frame header."""
    start = 0
    if data[:3] == b"ID3" and len(data) >= 10:
        size = data[6:10]
        start = 10 + ((size[0] << 21) | (size[1] << 14) | (size[2] << 7) | size[3])
    for offset in range(start, len(data) - 3):
        if data[offset] == 0xFF and data[offset + 1] & 0xE0 == 0xE0:
            mpeg1 = bool(data[offset + 1] & 0x08)
            index = data[offset + 2] >> 4
            if 0 < index < 15:
                kbps = (_MPEG1_L3_KBPS if mpeg1 else _MPEG2_L3_KBPS)[index]
                return (len(data) - offset) * 8 / (kbps * 1000)
    return 0.0


def _espeak(text: str, lang: Language, cache_dir: Path) -> Utterance:
    path = _cache_path(cache_dir, text, lang.espeak_voice, "espeak", ".wav")
    if not path.exists():
        write_atomically(path, encode_wav(espeak_samples(text, lang.espeak_voice), RATE))
    return Utterance(text, path, "espeak", lang.espeak_voice, _wav_duration(path))


def _gtts(text: str, lang: Language, cache_dir: Path) -> Utterance:
    """gTTS through memory, so a failed request writes nothing to disk."""
    global _gtts_failed_at
    voice = f"gtts-{lang.gtts_lang}"
    path = _cache_path(cache_dir, text, voice, "gtts", ".mp3")
    if not path.exists():
        from gtts import gTTS  # type: ignore[import-untyped]  # late: it pulls in requests

        buffer = io.BytesIO()
        try:
            gTTS(text, lang=lang.gtts_lang, lang_check=False, timeout=GTTS_TIMEOUT_S).write_to_fp(
                buffer
            )
        except Exception as error:  # gTTSError, requests' errors, ValueError on bad input
            _gtts_failed_at = time.monotonic()
            first = str(error).strip().splitlines()
            raise SynthesisError(
                f"gTTS failed: {first[0] if first else type(error).__name__}"
            ) from None
        if not buffer.getvalue():
            _gtts_failed_at = time.monotonic()
            raise SynthesisError("gTTS returned no audio")
        write_atomically(path, buffer.getvalue())
    return Utterance(text, path, "gtts", voice, mp3_duration(path.read_bytes()))


def _gtts_recently_failed() -> bool:
    return _gtts_failed_at is not None and time.monotonic() - _gtts_failed_at < GTTS_RETRY_S


def synthesize(
    text: str,
    language_code: str | Language,
    engine: Engine = "auto",
    cache_dir: Path | None = None,
) -> Utterance:
    """Speak `text`: "auto" tries gTTS (if it has not just failed), then espeak-ng.

    Raises `SynthesisError` (one line) only when the chosen engine, or for
    "auto" every engine, fails; `UnknownLanguage` for an unknown code.
    """
    lang = language_code if isinstance(language_code, Language) else language(language_code)
    folder = cache_dir if cache_dir is not None else cache_dir_default()
    if not text.strip():
        raise SynthesisError("nothing to say: the text is empty")
    if engine == "espeak":
        return _espeak(text, lang, folder)
    if engine == "gtts":
        return _gtts(text, lang, folder)
    cached = _cache_path(folder, text, f"gtts-{lang.gtts_lang}", "gtts", ".mp3")
    if cached.exists() or not _gtts_recently_failed():
        try:
            return _gtts(text, lang, folder)
        except SynthesisError:
            pass  # offline or refused: the offline voice speaks instead
    return _espeak(text, lang, folder)


def forget_gtts_failure() -> None:
    """Ask gTTS again on the next "auto" synthesis (e.g. after the network came back)."""
    global _gtts_failed_at
    _gtts_failed_at = None
