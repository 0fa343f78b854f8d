"""`tandem execute ... --responses voice:mic` through the virtual microphone.

A subprocess runs the English default scenario with the microphone and its
speakers on the virtual device (`tests.audio_device`). The test is the person
in the room: it answers each question aloud once the robot has stopped talking
(its sentence played into the same device), and types the sensing nodes'
answers on the console. After the first answer the device is unplugged: the
voice ends with one line, the rest is answered on the console, and the
session is stored.
"""

from __future__ import annotations

import os
import re
import subprocess
import threading
import time
from pathlib import Path

from app.sessions.store import SessionStore
from tests.audio_device import SoundServer, microphone, sound_server  # noqa: F401
from tests.plan_fixtures import ROOT, tandem_command
from tests.test_voice_mic import spoken

ENGLISH_DEFAULT = ROOT / "static" / "scenarios" / "default.toml"
QUESTION = re.compile(r'robot says \(espeak\): ".*\?"')


class Person:
    """Reads the run's stderr as it comes and answers: aloud after a question, typed
    at a console prompt; unplugs the device once the first answer has been taken."""

    def __init__(self, run: subprocess.Popen[bytes], device: SoundServer) -> None:
        self.run = run
        self.device = device
        self.text = ""
        self.spoken = 0
        self.typed = 0
        self.unplugged = False

    def follow(self) -> None:
        assert self.run.stderr is not None and self.run.stdin is not None
        seen = 0
        while chunk := os.read(self.run.stderr.fileno(), 4096):
            self.text += chunk.decode(errors="replace")
            new, seen = self.text[seen:], len(self.text)
            for _ in QUESTION.finditer(new):
                if not self.unplugged:
                    threading.Thread(target=self._answer, daemon=True).start()
            for _ in re.finditer(r"choice> ", new):
                # The human holds a part at the first sensing: the path with two questions.
                self.run.stdin.write(b"2\n" if self.typed == 0 else b"1\n")
                self.run.stdin.flush()
                self.typed += 1
            if not self.unplugged and re.search(r"heard '[^']+' \(confidence [\d.]+, try \d\): yes",
                                                self.text):  # fmt: skip
                self.unplugged = True
                self.device.unplug()

    def _answer(self) -> None:
        """"yes", 0.4 s after the robot's sentence has ended (its playback gone)."""
        deadline = time.monotonic() + 20
        time.sleep(0.3)
        while self.device.pactl("list", "short", "sink-inputs").strip():
            if time.monotonic() > deadline:
                return
            time.sleep(0.05)
        time.sleep(0.4)
        if not self.unplugged:
            self.spoken += 1
            self.device.play(spoken("yes"), "yes").wait(10)


def test_voice_mic_on_the_command_line_through_the_device(
    microphone: SoundServer, tmp_path: Path  # noqa: F811
) -> None:
    data = tmp_path / "data"
    env = {**microphone.env, "TANDEM_DATA_DIR": str(data)}
    env.pop("TANDEM_VOSK_MODEL", None)
    run = subprocess.Popen(
        [*tandem_command(), "execute", str(ENGLISH_DEFAULT), "--responses", "voice:mic",
         "--seed", "1"],
        cwd=ROOT, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    person = Person(run, microphone)
    following = threading.Thread(target=person.follow, daemon=True)
    following.start()
    try:
        run.wait(300)  # stdin stays open: the console answers come as asked
    finally:
        run.kill()
    following.join(10)
    assert run.stdout is not None
    out = run.stdout.read().decode()
    err = person.text
    assert run.returncode == 0, err
    assert person.unplugged, err
    # The voice ended with one line; the execution went on, answered on the console.
    ended = [line for line in err.splitlines() if line.startswith("the voice has ended (")]
    assert len(ended) == 1, err
    assert "choice> " in err.split(ended[0])[1], err
    session_id = int(out.split()[1])
    with SessionStore(data) as store:
        record = store.get(session_id)
        events = store.events(session_id)
        plan = store.plan(record.plan_hash)
    assert record.result == "goal" and record.clock == "wall"
    questions = [e for e in events if e.kind == "communication" and plan.nodes[e.node].outcomes]
    assert questions[0].source == "voice" and questions[0].outcome == "yes", questions
    assert all(e.source == "console" for e in questions[1:]), [e.source for e in questions]
    assert any(e.kind == "fell-back" and "the voice has ended" in (e.text or "") for e in events)
    # The robot's sentences reached the microphone, and none was taken as an answer.
    own = [e for e in events if e.kind == "own-voice"]
    taken = re.findall(r"heard '[^']*' \(confidence [\d.]+, try \d\): (yes|no)\b", err)
    assert own and taken == ["yes"], err
    assert not microphone.recording_streams()
