"""Speech benchmark: `python -m speech.bench` prints four tables.

1. TTS time per sentence with espeak-ng, cold (synthesized) and cached, and
   with "auto" (gTTS first: offline it fails, espeak-ng speaks).
2. Accuracy on the synthetic Korean test set (`speech.evaluation`), two seeds,
   with the table per answer word.
3. Recognition time per clip (`Recognizer.recognize`, the clip in hand).
4. Latency after the end of speech, as the microphone sees it: each answer is
   streamed in 30 ms blocks through `EndOfSpeech` (the microphone's cut) and
   into a `Decoding` as it comes; latency = cut time - true end of speech +
   the decoding's last step (target <= 0.5 s).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from speech.audio import RATE, Recording
from speech.evaluation import KOREAN_NO, KOREAN_YES, korean_trials, score
from speech.recognition import Heard, Recognizer
from speech.sources import SimulatedVoice
from speech.synthesis import forget_gtts_failure, synthesize
from speech.voice_activity import EndOfSpeech, LiveUtterance

SENTENCES = (
    ("en-us", "Can you help me attach leg two to the top?"),
    ("en-us", "I will hold the top for you."),
    ("en-us", "Is the first leg attached?"),
    ("ko", "다리를 붙이는 것을 도와줄 수 있어요?"),
    ("ko", "상판을 잡아 줄게요."),
)


def _tts_table(folder: Path) -> str:
    lines = [
        f"{'language':<8} {'cold ms':>8} {'cached ms':>10} {'auto ms':>8} {'auto by':>8} "
        f"{'audio s':>8}  sentence"
    ]
    for code, text in SENTENCES:
        started = time.perf_counter()
        utterance = synthesize(text, code, engine="espeak", cache_dir=folder / "espeak")
        cold = time.perf_counter() - started
        cached = []
        for _ in range(5):
            started = time.perf_counter()
            synthesize(text, code, engine="espeak", cache_dir=folder / "espeak")
            cached.append(time.perf_counter() - started)
        forget_gtts_failure()  # every row pays gTTS's first attempt, as a fresh process does
        started = time.perf_counter()
        auto = synthesize(text, code, engine="auto", cache_dir=folder / "auto")
        auto_s = time.perf_counter() - started
        lines.append(
            f"{code:<8} {1000 * cold:8.1f} {1000 * statistics.median(cached):10.2f} "
            f"{1000 * auto_s:8.1f} {auto.engine:>8} {utterance.duration_s:8.2f}  {text}"
        )
    return "\n".join(lines)


def _speech_end(samples: np.ndarray) -> float:
    """Seconds to the last sample above 1 % of the peak: where the speech really ends."""
    loud = np.flatnonzero(np.abs(samples.astype(np.int32)) > 0.01 * np.abs(samples).max())
    return float(loud[-1] + 1) / RATE if loud.size else 0.0


def end_of_speech_latencies(recognizer: Recognizer, seed: int = 7) -> list[float]:
    """Seconds from the end of each answer to its recognised result (see the docstring)."""
    block = int(EndOfSpeech(0.03).block_s * RATE)
    noise = np.random.default_rng(seed)
    latencies = []
    for index, phrase in enumerate((*KOREAN_YES, *KOREAN_NO) * 4):
        voice = SimulatedVoice("ko", seed=seed + index, pause_s=1.2)
        clean = voice.render(phrase).samples
        end = _speech_end(clean)
        stream = clean.astype(np.float64)
        if index % 2:  # half with white noise at 20 dB SNR
            speech = stream[stream != 0]
            sigma = np.sqrt(np.mean(speech * speech) / 100) if speech.size else 0.0
            stream = stream + noise.normal(0.0, sigma, stream.size)
        samples = np.clip(np.round(stream), -32768, 32767).astype(np.int16)
        # As the microphone does: each block as it comes, into a decoding that
        # finishes once the pause has passed.
        decoding = recognizer.start()
        utterance = LiveUtterance(EndOfSpeech(0.03), decoding.feed)
        for number in range(len(samples) // block):
            if utterance.push(samples[number * block : (number + 1) * block]):
                break
        cut_s = (number + 1) * block / RATE
        started = time.perf_counter()
        decoding.finish()
        latencies.append(cut_s - end + time.perf_counter() - started)
    return latencies


def _spread(values: list[float]) -> str:
    ordered = sorted(values)
    return (
        f"median {1000 * statistics.median(ordered):.0f} ms, "
        f"90th percentile {1000 * ordered[int(0.9 * len(ordered))]:.0f} ms, "
        f"max {1000 * ordered[-1]:.0f} ms"
    )


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        print("Text to speech (espeak-ng, 16 kHz WAV; auto: gTTS first, else espeak-ng)")
        print(_tts_table(Path(folder)))
    started = time.perf_counter()
    recognizer = Recognizer("ko")
    print(f"\nKorean model loaded in {time.perf_counter() - started:.2f} s")
    latencies: list[float] = []
    for seed in (7, 101):
        trials = korean_trials(seed=seed)

        def timed(recording: Recording) -> Heard:
            heard = recognizer.recognize_recording(recording)
            latencies.append(heard.decode_s)
            return heard

        result, misses = score(trials, timed)
        print(
            f"\nAccuracy, seed {seed} (targets: correct >= 85 %, wrong <= 3 %, "
            "non-answers rejected >= 80 %)"
        )
        print(result.table())
        print(result.phrase_table())
        print("\n".join(misses))
    print(f"\nRecognition time per clip, {len(latencies)} clips: {_spread(latencies)}")
    after_end = end_of_speech_latencies(recognizer)
    print(
        f"Latency after the end of speech (the microphone's {EndOfSpeech(0.03).pause_s:.2f} s "
        f"pause + the end of the decoding), {len(after_end)} answers: {_spread(after_end)} "
        "(target <= 500 ms)"
    )


if __name__ == "__main__":
    main()
