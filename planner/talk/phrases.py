"""What the robot says for each communication action, and why."""

from __future__ import annotations

import functools

from planner.vocabulary import (
    CONVERSATION,
    AskHelp,
    Communication,
    ConfirmAttach,
    ExplainAsk,
    ExplainOwnTask,
    Farewell,
    Greet,
    OfferHelp,
    RequestToAttach,
    RequestToUnhold,
    Reserved,
    State,
    WarnDanger,
    WarnWorking,
    parse_term,
)


def _the(part: str) -> str:
    return f"the {part}"


TERSE = {
    ConfirmAttach.name: "Attaching the {0} to the {1}?",
    AskHelp.name: "Please help: the {0} onto the {1}?",
    OfferHelp.name: "The {0} is sharp. Shall I?",
    RequestToUnhold.name: "Please put the {0} down.",
    RequestToAttach.name: "Please attach the {0} to the {1}.",
    Greet.name: "Hello.",
    Farewell.name: "Done. Thank you.",
    WarnWorking.name: "Mind your hands: I work in the {0} region.",
    WarnDanger.name: "Careful: the {0} is sharp.",
    ExplainAsk.name: "I cannot reach the {0}.",
    ExplainOwnTask.name: "The {0} is sharp; I will do it.",
}


# Korean: "부품" after a part's name spares choosing 을/를 by its last sound.
KOREAN_TERSE = {
    ConfirmAttach.name: "{0} 부품을 {1}에 붙이세요?",
    AskHelp.name: "{0} 부품을 {1}에 붙여 주시겠어요?",
    OfferHelp.name: "{0} 부품은 날카로워요. 제가 할까요?",
    RequestToUnhold.name: "{0} 부품을 내려놓아 주세요.",
    RequestToAttach.name: "{0} 부품을 {1}에 붙여 주세요.",
    Greet.name: "안녕하세요.",
    Farewell.name: "끝났어요. 감사합니다.",
    WarnWorking.name: "{0} 구역에서 작업해요. 손 조심하세요.",
    WarnDanger.name: "{0} 부품은 날카로워요.",
    ExplainAsk.name: "{0} 부품에 손이 닿지 않아요.",
    ExplainOwnTask.name: "{0} 부품은 제가 할게요.",
}
KOREAN = {
    ConfirmAttach.name: "{0} 부품을 들고 계시네요. {1}에 붙이실 건가요?",
    AskHelp.name: "{0} 부품에 손이 닿지 않아요. {1}에 붙여 주시겠어요?",
    OfferHelp.name: "조심하세요, {0} 부품은 날카로워요. 제가 {1}에 붙여 드릴까요?",
    RequestToUnhold.name: "{0} 부품을 내려놓아 주세요. 제가 처리할게요.",
    RequestToAttach.name: "{0} 부품을 {1}에 붙여 주세요. 꼭 필요한데 제 손이 닿지 않아요.",
    Greet.name: "안녕하세요! 함께 테이블을 만들어요.",
    Farewell.name: "테이블이 완성됐어요. 도와주셔서 감사합니다!",
    WarnWorking.name: "조심하세요, 제가 {0} 구역에서 작업할게요. 손을 조심해 주세요.",
    WarnDanger.name: "조심하세요, {0} 부품은 날카로워요. 만지지 마세요.",
    ExplainAsk.name: "{0} 부품에 제 팔이 닿지 않아서 도움을 부탁드릴게요.",
    ExplainOwnTask.name: "{0} 부품은 날카로워서 제가 직접 붙일게요.",
}


def say(
    action: Communication, verbosity: str = "normal", reason: str = "", language: str = "en-us"
) -> str:
    """The sentence spoken in `language`; `terse` is short, `chatty` adds the reason
    (the reason is written in English only, so a Korean sentence goes without it)."""
    if language == "ko":
        table = KOREAN_TERSE if verbosity == "terse" else KOREAN
        return table[action.name].format(*action.arguments)
    if verbosity == "terse":
        return TERSE[action.name].format(*action.arguments)
    sentence = _say_normal(action)
    # An explanation is its own reason; greetings and warnings need none spoken.
    if verbosity == "chatty" and reason and action.name not in CONVERSATION:
        return f"{sentence} ({reason})"
    return sentence


def _say_normal(action: Communication) -> str:
    match action:
        case ConfirmAttach(p, q):
            return f"I see you are holding {_the(p)}. Are you going to attach it to {_the(q)}?"
        case AskHelp(p, q):
            return f"I cannot reach {_the(p)}. Could you attach it to {_the(q)}, please?"
        case OfferHelp(p, q):
            return f"Careful, {_the(p)} is sharp. Shall I attach it to {_the(q)} for you?"
        case RequestToUnhold(p):
            return f"Please put {_the(p)} down; I will take care of it."
        case RequestToAttach(p, q):
            return (
                f"Please attach {_the(p)} to {_the(q)}; the table needs it and I cannot reach it."
            )
        case Greet():
            return "Hello! Let's build the table together."
        case Farewell():
            return "The table is done. Thank you for your help, goodbye!"
        case WarnWorking(r):
            return f"Careful, I am going to work in the {r} region; please mind your hands."
        case WarnDanger(d):
            return f"Careful, {_the(d)} is sharp; please keep your hands off it."
        case ExplainAsk(p):
            return f"I cannot reach {_the(p)} with either arm, so I will ask you for help with it."
        case ExplainOwnTask(p):
            return f"{_the(p).capitalize()} is sharp, so I will attach it myself."
    raise ValueError(f"not a communication action: {action}")


def _region(part: str, facts: frozenset[str]) -> str:
    return _regions(facts).get(part, "?")


@functools.lru_cache(maxsize=8)
def _regions(facts: frozenset[str]) -> dict[str, str]:
    """Each part's region (`loc/2`), read once per plan's facts: a large plan
    explains hundreds of nodes with the same facts."""
    out: dict[str, str] = {}
    for text in facts:
        if text.startswith("loc("):
            term = parse_term(text)
            if len(term.args) == 2:
                out.setdefault(term.args[0].name, term.args[1].name)
    return out


def why(action: Communication, state: State, facts: frozenset[str]) -> str:
    match action:
        case ConfirmAttach(p, q):
            return (
                f"The human holds {p}, which the final configuration attaches to {q}; "
                "knowing their intention avoids working on the same part."
            )
        case AskHelp(p, _):
            return (
                f"No arm can reach {p} in region {_region(p, facts)} (reachability failed for "
                f"every manipulator), and {p} is safe for the human to handle."
            )
        case OfferHelp(p, _):
            return (
                f"{p} is dangerous for the human to handle and an arm can reach it, "
                "so the robot offers to do the attachment."
            )
        case RequestToUnhold(p):
            if str(Reserved(p)) in state:
                return (
                    f"The human said they will not attach {p}; the robot needs it or its place."
                )
            return f"{p} in the human's hands blocks the next steps of the plan."
        case RequestToAttach(p, _):
            return (
                f"No arm can reach {p} in region {_region(p, facts)} and the human declined to "
                "help; without it the table cannot be finished."
            )
        case Greet():
            return "Opening the conversation: the human knows the robot is ready to work with them."
        case Farewell():
            return "Every attachment of the final configuration is made: the work is over."
        case WarnWorking(r):
            return (
                "The human holds a part, so their hands are at the bench, and the next arm "
                f"motion is in region {r}, which the human reaches."
            )
        case WarnDanger(d):
            return (
                f"The robot is about to send the human into region {_region(d, facts)}, where "
                f"the dangerous {d} lies loose."
            )
        case ExplainAsk(p):
            return (
                f"No arm can reach {p} in region {_region(p, facts)}: the human hears why they "
                "are asked before the question."
            )
        case ExplainOwnTask(p):
            return (
                f"{p} is dangerous and lies where the human reaches it: the human hears why the "
                "robot takes it."
            )
    raise ValueError(f"not a communication action: {action}")
