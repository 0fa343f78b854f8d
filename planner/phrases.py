"""What the robot says for each communication action, and why."""

from __future__ import annotations

import clingo


def _args(action: str) -> tuple[str, list[str]]:
    term = clingo.parse_term(action)
    return term.name, [str(a) for a in term.arguments]


def _the(part: str) -> str:
    return f"the {part}"


TERSE = {
    "confirmAttach": "Attaching the {0} to the {1}?",
    "askHelp": "Please help: the {0} onto the {1}?",
    "offerHelp": "The {0} is sharp. Shall I?",
    "requestToUnhold": "Please put the {0} down.",
    "requestToAttach": "Please attach the {0} to the {1}.",
}


def say(action: str, verbosity: str = "normal", reason: str = "") -> str:
    """The sentence spoken; `terse` is short, `chatty` adds the reason."""
    name, args = _args(action)
    if verbosity == "terse" and name in TERSE:
        return TERSE[name].format(*args)
    sentence = _say_normal(name, args, action)
    if verbosity == "chatty" and reason:
        return f"{sentence} ({reason})"
    return sentence


def _say_normal(name: str, args: list[str], action: str) -> str:
    if name == "confirmAttach":
        p, q = args
        return f"I see you are holding {_the(p)}. Are you going to attach it to {_the(q)}?"
    if name == "askHelp":
        p, q = args
        return f"I cannot reach {_the(p)}. Could you attach it to {_the(q)}, please?"
    if name == "offerHelp":
        p, q = args
        return f"Careful, {_the(p)} is sharp. Shall I attach it to {_the(q)} for you?"
    if name == "requestToUnhold":
        (p,) = args
        return f"Please put {_the(p)} down; I will take care of it."
    if name == "requestToAttach":
        p, q = args
        return f"Please attach {_the(p)} to {_the(q)}; the table needs it and I cannot reach it."
    raise ValueError(f"not a communication action: {action}")


def why(action: str, state: frozenset[str], facts: frozenset[str]) -> str:
    name, args = _args(action)
    p = args[0]
    region = next((f[len(f"loc({p},") : -1] for f in facts if f.startswith(f"loc({p},")), "?")
    if name == "confirmAttach":
        return (
            f"The human holds {p}, which the final configuration attaches to {args[1]}; "
            "knowing their intention avoids working on the same part."
        )
    if name == "askHelp":
        return (
            f"No arm can reach {p} in region {region} (reachability failed for every "
            f"manipulator), and {p} is safe for the human to handle."
        )
    if name == "offerHelp":
        return (
            f"{p} is dangerous for the human to handle and an arm can reach it, "
            "so the robot offers to do the attachment."
        )
    if name == "requestToUnhold":
        if f"reserved({p})" in state:
            return f"The human said they will not attach {p}; the robot needs it or its place."
        return f"{p} in the human's hands blocks the next steps of the plan."
    if name == "requestToAttach":
        return (
            f"No arm can reach {p} in region {region} and the human declined to help; "
            "without it the table cannot be finished."
        )
    raise ValueError(f"not a communication action: {action}")
