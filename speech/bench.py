"""Speech benchmark: `python -m speech.bench` prints three tables.

1. TTS time per sentence with espeak-ng, cold (synthesized) and cached.
2. Recognition latency after the end of speech: the whole clip is in hand
   when speech ends, so the latency is `Recognizer.recognize`'s time (median;
   target <= 0.5 s).
3. Accuracy on the synthetic Korean test set (`speech.evaluation`), two seeds.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from speech.audio import Recording
from speech.evaluation import korean_trials, score
from speech.recognition import Heard, Recognizer
from speech.synthesis import synthesize

SENTENCES = (
    ("en-us", "Can you help me attach leg two to the top?"),
    ("en-us", "I will hold the top for you."),
    ("en-us", "Is the first leg attached?"),
    ("ko", "다리를 붙이는 것을 도와줄 수 있어요?"),
    ("ko", "상판을 잡아 줄게요."),
)


def _tts_table(folder: Path) -> str:
    lines = [f"{'language':<8} {'cold ms':>8} {'cached ms':>10} {'audio s':>8}  sentence"]
    for code, text in SENTENCES:
        started = time.perf_counter()
        utterance = synthesize(text, code, engine="espeak", cache_dir=folder)
        cold = time.perf_counter() - started
        cached = []
        for _ in range(5):
            started = time.perf_counter()
            synthesize(text, code, engine="espeak", cache_dir=folder)
            cached.append(time.perf_counter() - started)
        lines.append(
            f"{code:<8} {1000 * cold:8.1f} {1000 * statistics.median(cached):10.2f} "
            f"{utterance.duration_s:8.2f}  {text}"
        )
    return "\n".join(lines)


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        print("Text to speech (espeak-ng, 16 kHz WAV)")
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

        result, _ = score(trials, timed)
        print(
            f"\nAccuracy, seed {seed} (targets: correct >= 85 %, wrong <= 3 %, "
            "non-answers rejected >= 80 %)"
        )
        print(result.table())
        print(result.phrase_table())
    latencies.sort()
    print(
        f"\nRecognition latency after the end of speech, {len(latencies)} clips: "
        f"median {1000 * statistics.median(latencies):.0f} ms, "
        f"90th percentile {1000 * latencies[int(0.9 * len(latencies))]:.0f} ms, "
        f"max {1000 * latencies[-1]:.0f} ms (target <= 500 ms)"
    )


if __name__ == "__main__":
    main()
