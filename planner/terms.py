"""A small parser for ASP terms as they appear in plan files (`attach(left,top,c1)`).

Plain Python on purpose: the plan audit must not depend on clingo.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class Term:
    """A ground term such as `sense(humanAttachingWhere(leg2,top))`."""

    name: str
    args: tuple[Term, ...] = ()

    def __str__(self) -> str:
        if not self.args:
            return self.name
        return f"{self.name}({','.join(str(a) for a in self.args)})"


class TermError(ValueError):
    """A string that is not a ground term."""


_TOKEN = re.compile(
    r"\s*(?:(?P<id>[a-z_][A-Za-z0-9_]*)|(?P<num>-?[0-9]+)"
    r'|(?P<str>"(?:[^"\\]|\\.)*")|(?P<punct>[(),]))'
)
_PUNCT = frozenset("(),")


def parse_term(text: str) -> Term:
    """Parse a ground ASP term: constants, integers, strings, nested functions."""
    tokens: list[str] = []
    pos = 0
    text = text.strip()  # _TOKEN skips leading blanks, so only trailing ones remain
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise TermError(f"cannot parse {text!r} at position {pos}")
        tokens.append(m.group(m.lastgroup or "punct"))
        pos = m.end()
    term, rest = _parse_tokens(text, tokens, 0)
    if rest != len(tokens):
        raise TermError(f"cannot parse {text!r}: unexpected {tokens[rest]!r}")
    return term


def _parse_tokens(text: str, tokens: list[str], i: int) -> tuple[Term, int]:
    if i >= len(tokens) or tokens[i] in _PUNCT:
        raise TermError(f"cannot parse {text!r}: expected a name")
    name = tokens[i]
    i += 1
    if i >= len(tokens) or tokens[i] != "(":
        return Term(name), i
    if not re.fullmatch(r"[a-z_][A-Za-z0-9_]*", name):
        raise TermError(f"cannot parse {text!r}: {name!r} cannot take arguments")
    args: list[Term] = []
    i += 1
    while True:
        arg, i = _parse_tokens(text, tokens, i)
        args.append(arg)
        if i < len(tokens) and tokens[i] == ",":
            i += 1
            continue
        if i < len(tokens) and tokens[i] == ")":
            return Term(name, tuple(args)), i + 1
        raise TermError(f"cannot parse {text!r}: expected ',' or ')'")


def constants(term: Term) -> tuple[str, ...] | None:
    """The arguments of `term` as plain strings, or None if any is nested."""
    if any(a.args for a in term.args):
        return None
    return tuple(a.name for a in term.args)
