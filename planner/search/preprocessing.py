"""The planning program after clasp's own preprocessing, for large benches.

clingo starts a program step on every solve, and clasp then preprocesses the
rule bodies of the whole program again (docs/domain.md): a solve pays for the
bodies and equivalences of the ground program, not only for its search. clasp's
preprocessing (`--pre`) leaves fewer of them (U14, horizon 3: 27,749 -> 21,600
bodies, 46,433 -> 28,841 equivalences), and a `Control` that loads that program
(aspif) instead of grounding the encodings solves the same states in about 15 %
less time, with the same answers (U14, 300 states at horizons 3 and 4).

The clingo library refuses `--pre`; the clingo application accepts it, so each
program is made by it in a child process (`python -m planner.search.preprocessing
REQUEST`), before planning starts, and loaded by every process that solves
(`load_preprocessed`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import clingo

from planner.search.encoding import ClingoMessages, EncodingError, FeasibilityContext, ground_into

# Shown so that the loaded program still names the externals a state is assumed
# through (preprocessing numbers atoms anew, and only shown ones keep a name).
NAMED_EXTERNALS = "#show init/1. #show forbid/1."


@dataclass(frozen=True)
class ProgramRequest:
    """What `ground` would be given: facts, horizon, reachable pairs, concerns left out."""

    facts: tuple[str, ...]
    horizon: int
    reachable: tuple[tuple[str, str], ...]
    skip: tuple[str, ...] = ()


def preprocessed(requests: Sequence[ProgramRequest]) -> list[str]:
    """The preprocessed program (aspif text) of each request, made side by side."""
    with tempfile.TemporaryDirectory(prefix="tandem-pre-") as tmp:
        running = []
        for i, request in enumerate(requests):
            asked, made = Path(tmp, f"{i}.json"), Path(tmp, f"{i}.aspif")
            asked.write_text(json.dumps(asdict(request)))
            with made.open("w") as out:
                child = subprocess.Popen(
                    [sys.executable, "-m", __name__, str(asked)],
                    stdout=out, stderr=subprocess.PIPE, text=True, env=_env(),
                )  # fmt: skip
            running.append((child, made))
        programs = []
        try:
            for child, made in running:
                _, err = child.communicate()
                if child.returncode != 0:
                    why = _reason(err) or f"exit status {child.returncode}"
                    raise EncodingError(f"clasp's preprocessing failed: {why}")
                programs.append(made.read_text())
        finally:
            for child, _ in running:
                if child.poll() is None:
                    child.kill()  # its program is not wanted any more
                    child.wait()
    return programs


def load_preprocessed(program: str, options: Sequence[str] = ()) -> clingo.Control:
    """A `Control` holding `program` (aspif), ready to solve; its shown `init/1` and
    `forbid/1` atoms stand for the externals (`solver._externals` frees them)."""
    ctl = clingo.Control([*options, "--warn=none"])
    # clingo reads aspif from files only.
    with tempfile.NamedTemporaryFile("w", suffix=".aspif", prefix="tandem-") as f:
        f.write(program)
        f.flush()
        ctl.load(f.name)
    ctl.ground([("base", [])])
    return ctl


def _reason(stderr: str) -> str:
    """One line of the child's report: clingo's first error, else its last line."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    errors = [line for line in lines if ": error:" in line]
    return (errors or lines or [""])[0 if errors else -1]


def _env() -> dict[str, str]:
    """The child's environment: this package importable, wherever it was found, and
    its C output buffered. clingo writes the program a token at a time through C's
    stdout, which PYTHONUNBUFFERED leaves unbuffered: 2.3 million writes for U30's
    program a step short, 2.4-2.5 s of which 1.5-1.7 s in the kernel, against
    0.67 s buffered (the same program)."""
    root = str(Path(__file__).resolve().parents[2])
    path = os.environ.get("PYTHONPATH")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return {**env, "PYTHONPATH": root if not path else f"{root}{os.pathsep}{path}"}


class _Preprocess(clingo.Application):
    """clingo with `--pre=aspif`: grounds the request and prints clasp's program."""

    program_name = "tandem-preprocess"

    def __init__(self, request: ProgramRequest) -> None:
        self.request = request
        self.error: EncodingError | None = None

    def main(self, ctl: clingo.Control, files: Sequence[str]) -> None:
        reachable = set(self.request.reachable)
        context = FeasibilityContext(lambda m, p: (m, p) in reachable)
        messages = ClingoMessages(expect_undefined=bool(self.request.skip))
        try:
            ground_into(
                ctl, self.request.facts, context, messages,
                skip=self.request.skip, rules=NAMED_EXTERNALS,
            )  # fmt: skip
        except EncodingError as err:
            self.error = err  # told by `main`, clingo's own report left out
            return
        ctl.solve()


def main(argv: Sequence[str]) -> int:
    raw = json.loads(Path(argv[0]).read_text())
    request = ProgramRequest(
        facts=tuple(raw["facts"]),
        horizon=raw["horizon"],
        reachable=tuple((m, p) for m, p in raw["reachable"]),
        skip=tuple(raw["skip"]),
    )
    args = ["--pre=aspif", "-c", f"h={request.horizon}", "--warn=none"]
    app = _Preprocess(request)
    code = clingo.clingo_main(app, args)
    if app.error is not None:
        print(app.error, file=sys.stderr)
        return 2
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
