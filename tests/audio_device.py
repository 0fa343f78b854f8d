"""A real audio device for the voice tests: a virtual microphone on a sound server.

`sound_server` (session-scoped) starts a private PulseAudio daemon (Debian
`pulseaudio`, installed by `make system`) on its own socket, with one null sink
(`tandem_room`): whatever is played into the sink is recorded by its monitor,
the server's default source, which PortAudio opens through ALSA's pulse
plugin (`libasound2-plugins`). The tests play speech into it in real time with
`paplay`, as a person would speak into a microphone, and the robot's own lines
played on the default output land in the same sink, as a loudspeaker's sound
reaches a microphone in a room.

`microphone` (per test) points this process at the server (`PULSE_SERVER`) and
has PortAudio list its devices again; afterwards the process sees the
machine's own devices again (other tests check what happens without any).
`env` is the environment for a `tandem` subprocess that uses the device.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from speech.audio import RATE, Samples, encode_wav
from speech.devices import rescan
from speech.microphone import close_all

SINK = "tandem_room"


@dataclass(frozen=True)
class SoundServer:
    """The private PulseAudio server: its socket and the null sink it records."""

    folder: Path
    server: str  # "unix:<socket>", for PULSE_SERVER or --server

    @property
    def env(self) -> dict[str, str]:
        return {**os.environ, "PULSE_SERVER": self.server}

    def pactl(self, *args: str) -> str:
        done = subprocess.run(
            ["pactl", "--server", self.server, *args],
            capture_output=True, text=True, timeout=20, check=True,
        )  # fmt: skip
        return done.stdout

    def play(self, samples: Samples, name: str = "speech") -> subprocess.Popen[bytes]:
        """Plays 16 kHz `samples` into the sink in real time (a person speaking), from
        0.3 s on; the returned process ends when the sound has been played."""
        path = self.folder / f"{name}-{time.monotonic_ns()}.wav"
        # Led by 0.3 s of silence: a stream that joins a sink already playing (the robot's
        # speakers) is mixed in by rewinding the sink, and its first tens of ms never
        # reach the monitor (the "s" of "stop" was lost so, and the word refused).
        lead = np.zeros(int(0.3 * RATE), dtype=np.int16)
        path.write_bytes(encode_wav(np.concatenate([lead, samples]), RATE))
        return subprocess.Popen(
            ["paplay", "--server", self.server, f"--device={SINK}", str(path)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip

    def recording_streams(self) -> list[str]:
        """The ids of the streams recording from the server (an open microphone)."""
        listed = self.pactl("list", "short", "source-outputs")
        return [line.split()[0] for line in listed.splitlines()]

    def unplug(self) -> None:
        """The device goes away, as a USB headset pulled out mid-session: its microphone
        and its speakers (the sink's module is unloaded)."""
        for line in self.pactl("list", "short", "modules").splitlines():
            if f"sink_name={SINK}" in line:
                self.pactl("unload-module", line.split()[0])

    def plug(self) -> None:
        """The device is there (again): the sink, the default output and its monitor
        the default input."""
        if f"sink_name={SINK}" not in self.pactl("list", "short", "modules"):
            self.pactl("load-module", "module-null-sink", f"sink_name={SINK}",
                       f"rate={RATE}", "channels=1")  # fmt: skip
        self.pactl("set-default-source", f"{SINK}.monitor")
        self.pactl("set-default-sink", SINK)


def _ends_with_parent() -> None:
    """The daemon is sent SIGTERM when the test process dies, however it dies."""
    libc = ctypes.CDLL(None)
    libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _start(folder: Path) -> tuple[subprocess.Popen[bytes], SoundServer]:
    socket = folder / "native"
    env = {**os.environ, "HOME": str(folder), "XDG_RUNTIME_DIR": str(folder)}
    env.pop("PULSE_SERVER", None)
    # Not --system (a machine-wide server) nor --daemonize (its pid is lost): a child
    # of this process, on its own socket, with no modules but the protocol (the sink
    # is loaded by `plug`), ended with it.
    daemon = subprocess.Popen(
        [
            "pulseaudio", "--daemonize=no", "-n", "--exit-idle-time=-1",
            "--use-pid-file=no", "--disallow-exit", "--disable-shm=yes",
            "-L", f"module-native-protocol-unix socket={socket} auth-anonymous=1",
            "--log-target=stderr",
        ],
        env=env, stdout=subprocess.DEVNULL, stderr=(folder / "pulseaudio.log").open("wb"),
        preexec_fn=_ends_with_parent,
    )  # fmt: skip
    server = SoundServer(folder, f"unix:{socket}")
    deadline = time.monotonic() + 20
    while True:
        try:
            server.plug()
            return daemon, server
        except subprocess.CalledProcessError:
            if daemon.poll() is not None or time.monotonic() > deadline:
                daemon.kill()
                log = (folder / "pulseaudio.log").read_text(errors="replace")
                pytest.fail(f"the sound server did not start: {log[-2000:]}")
            time.sleep(0.1)


@pytest.fixture(scope="session")
def sound_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SoundServer]:
    missing = [tool for tool in ("pulseaudio", "pactl", "paplay") if shutil.which(tool) is None]
    if missing:
        pytest.fail(f"{', '.join(missing)} missing: `make test` installs them (make system)")
    folder = tmp_path_factory.mktemp("sound")
    daemon, server = _start(folder)
    try:
        yield server
    finally:
        daemon.terminate()
        try:
            daemon.wait(10)
        except subprocess.TimeoutExpired:
            daemon.kill()


@pytest.fixture
def microphone(sound_server: SoundServer, monkeypatch: pytest.MonkeyPatch) -> Iterator[SoundServer]:
    sound_server.plug()  # a test before may have unplugged it
    monkeypatch.setenv("PULSE_SERVER", sound_server.server)
    monkeypatch.delenv("TANDEM_MICROPHONE", raising=False)
    rescan()
    yield sound_server
    # A test that failed may leave a microphone open: closed before PortAudio restarts.
    close_all()
    monkeypatch.undo()
    _rescan_within(10.0)


def _rescan_within(seconds: float) -> None:
    """PortAudio restarted, or a failure that says why instead of a hang: restarting it
    closes every stream still open, and one still playing in another thread (a line
    of the robot's after its execution ended) was waited on for ever."""
    restart = threading.Thread(target=rescan, name="portaudio-restart", daemon=True)
    restart.start()
    restart.join(seconds)
    if restart.is_alive():
        pytest.fail(f"PortAudio did not restart within {seconds:g} s: a stream was left open")
