"""The languages the robot speaks and understands, keyed by code ("en-us", "ko").

A `Language` carries everything the voice side needs for one language: the
espeak-ng voice and gTTS language for speaking, and for a yes/no question the
answer phrases and the distractor phrases. Distractors are words of the
recognition model's vocabulary that sound unlike any answer: put in the closed
grammar beside the answers, they absorb speech that is not an answer (the
Korean model has no `[unk]` word, so without them every sound is forced into
"yes" or "no"). Each answer or distractor is a phrase of one or more words the
model knows; the recogniser ignores words missing from the vocabulary.
"""

from __future__ import annotations

from dataclasses import dataclass


class UnknownLanguage(ValueError):
    """A language code that is not in the table."""


@dataclass(frozen=True)
class Language:
    code: str
    name: str
    espeak_voice: str
    gtts_lang: str
    yes_words: tuple[str, ...]
    no_words: tuple[str, ...]
    distractors: tuple[str, ...]
    # espeak-ng voice variants ("+m3", "+f2"...) a simulated speaker may use.
    espeak_variants: tuple[str, ...] = ("",)

    def meaning_of(self, phrase: str) -> str | None:
        """"yes", "no" or None for a phrase of this language's answers."""
        if phrase in self.yes_words:
            return "yes"
        if phrase in self.no_words:
            return "no"
        return None


_VARIANTS = ("", "+m1", "+m3", "+m7", "+f1", "+f2", "+f4", "+croak", "+klatt2")

ENGLISH = Language(
    code="en-us",
    name="English (America)",
    espeak_voice="en-us",
    gtts_lang="en",
    # Chosen by measurement (`speech.bench` prints the table per phrase): with
    # pocketsphinx's grammar of the answers, espeak-ng's "not yet" was heard as
    # "yeah" or "yes" 22 times in 48, "of course" as "sure" or "don't" and
    # "don't" as "go ahead" or "ok" 6 times in 48 each; every other phrase was
    # heard with its own meaning 45-48 times in 48. "not now" was dropped later:
    # through the live ear pocketsphinx heard its "not" as silence and "now" as
    # "no", so check 5 refused it as out of grammar (a simulated room's human, seed
    # 37), and the command grammar took it for a stop (2 of the 6 voices of
    # tests/test_speech_words.py). Said anyway, it is refused or heard as "no".
    yes_words=("yes", "yeah", "yep", "yes please", "sure", "okay", "ok", "go ahead"),
    no_words=("no", "nope", "no thanks", "no thank you"),
    distractors=(
        "table", "leg", "top", "robot", "hello", "what", "where", "wait", "maybe",
        "left", "right", "screw", "hold", "the", "a", "it", "is", "that", "this",
    ),
    espeak_variants=_VARIANTS,
)

KOREAN = Language(
    code="ko",
    name="Korean",
    espeak_voice="ko",
    gtts_lang="ko",
    # Chosen by measurement: each candidate the model knows was spoken by
    # espeak-ng's Korean voice 18-36 times (variants, speeds, pitches, noise)
    # and decoded in a grammar of the candidates. These six were heard as their
    # meaning most often (네 30/36, 좋아요 35/36, 맞아 36/36; 아니요 35/36,
    # 아니야 32/36, 됐어 33/36, in a grammar of just these). Common words were
    # far worse: 예, 응, 그래요, 싫어요, 아냐 2/18, 싫어 1/18 (heard as the other
    # answer or as nothing); and every extra word takes sounds from the rest.
    # `speech.bench` prints the table per word. 됐어 was dropped later: through the
    # live ear, in a microphone's noise floor, vosk refused it for 3 of 6 voices
    # (low confidence, or out of grammar by the distractors; tests/test_speech_words.py),
    # and besides "no thanks" it says "(it is) done", no answer to a yes/no question.
    yes_words=("네", "좋아요", "맞아"),
    no_words=("아니요", "아니야"),
    # Content words of the model's vocabulary, none near the answers: speech
    # that is not an answer is decoded as these. Single syllables were measured
    # too: they also absorb the onsets of real answers (fewer accepted, no fewer
    # wrong), so only whole words are kept; 셋 (took the short 네) and 사과 (took
    # the onset of 아니야) were dropped for the same reason.
    distractors=(
        "테이블", "다리", "하나", "둘", "로봇", "사람", "오늘", "볼트", "상판",
        "기다려", "잠깐", "오른쪽", "빨리", "다음", "처음", "마지막", "책상", "연필",
        "바다", "하늘", "구름", "바람", "학교", "전화", "컴퓨터", "음악",
        "바나나", "시간", "무엇", "어디", "저기",
        # Once an answer (above): as a distractor it is heard and refused, and it
        # keeps taking other speech (Korean non-answers refused, tuning seeds:
        # 90.5 % without it, 91.7 % with it; held-out 87.3 % and 92.1 %).
        "됐어",
    ),
    espeak_variants=_VARIANTS,
)

LANGUAGES: dict[str, Language] = {lang.code: lang for lang in (ENGLISH, KOREAN)}


def language(code: str) -> Language:
    """The language for a code; `UnknownLanguage` names the known ones."""
    try:
        return LANGUAGES[code]
    except KeyError:
        known = ", ".join(sorted(LANGUAGES))
        raise UnknownLanguage(f"unknown language {code!r} (known: {known})") from None
