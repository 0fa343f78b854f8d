"""How soon the live ear hears "stop": `python -m speech.dialogue_latency`.

For each seed the robot says a sentence into a `SimulatedRoom` and the simulated
human says a stop word, over the sentence (odd seeds) or after it; printed: how
many stops were heard and the seconds from the end of the word to the command.
"""

from __future__ import annotations

import threading
from pathlib import Path

from speech.audio import RATE
from speech.dialogue import BLOCK_S, COMMAND_WORDS, Commands, Ear


def stop_latency(code: str, seeds: range, cache: Path) -> list[float | None]:
    """Seconds from the end of a stop word to the ear's command, per seed (None: not
    heard); the word is said over the robot's sentence for odd seeds, in quiet else."""
    commands = Commands(code)
    return [_one_stop(commands, seed, cache) for seed in seeds]


def _one_stop(commands: Commands, seed: int, cache: Path) -> float | None:
    from speech.audio import read_wav, resample
    from speech.sources import SimulatedRoom, SimulatedVoice
    from speech.synthesis import synthesize

    code = commands.recognizer.language.code
    room = SimulatedRoom(seed)
    heard: list[float] = []
    ear = Ear(room, commands=commands, on_command=lambda c, h: heard.append(room.position_s))
    ear.start()
    text = "Can you hold the top for me?" if code == "en-us" else "상판을 잡아 줄게요."
    sentence = read_wav(synthesize(text, code, "espeak", cache).path)
    samples = resample(sentence.samples, sentence.rate, RATE)
    span = room.play_robot(samples, told=ear.robot_speaks)
    human = SimulatedVoice(code, seed=seed, room=room)
    stops = COMMAND_WORDS[code][0]
    human.say_at(stops[seed % len(stops)], span.start_s + 0.3 if seed % 2 else span.end_s + 0.5)
    said = human.spoken_at
    assert said is not None
    while room.position_s < said.end_s + 1.0:
        threading.Event().wait(BLOCK_S)
    ear.close()
    return heard[0] - said.speech_end_s if heard else None


if __name__ == "__main__":
    import statistics
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        for lang in ("ko", "en-us"):
            measured = stop_latency(lang, range(12), Path(folder))
            times = sorted(t for t in measured if t is not None)
            print(
                f"{lang}: stop heard {len(times)}/{len(measured)}; after the end of the "
                f"word: median {statistics.median(times):.3f} s, worst {times[-1]:.3f} s"
            )
