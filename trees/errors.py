"""Errors for bad mission input, each naming file:line:column, key path and expectation.

Every bad-input failure of the runtime (malformed YAML, unknown key, unknown
skill, wrong parameter type, subtree cycle, missing file …) raises
:class:`MissionError`; the CLI prints it and exits with code 2.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from typing import Any

KeyPathLike = Sequence[Any]


def suggest(name: Any, known: Iterable[Any]) -> str | None:
    """The known name closest to ``name`` (difflib ratio >= 0.6), or ``None``."""
    candidates = [str(k) for k in known]
    close = difflib.get_close_matches(str(name), candidates, n=1, cutoff=0.6)
    if not close:  # a case-only typo ("Sequence") is still a match
        lowered = {c.lower(): c for c in candidates}
        close = [lowered[m] for m in difflib.get_close_matches(str(name).lower(), list(lowered), n=1, cutoff=0.6)]
    return close[0] if close else None


def format_key_path(key_path: KeyPathLike) -> str:
    """``("tree", "sequence", 2, "params")`` -> ``"tree.sequence[2].params"``."""
    text = ""
    for item in key_path:
        if isinstance(item, int) and not isinstance(item, bool):
            text += f"[{item}]"
        else:
            text += f".{item}" if text else str(item)
    return text


def one_of(names: Iterable[Any]) -> str:
    """``"one of a, b, c"`` for an expectation listing the known names (sorted); a single name alone."""
    texts = sorted(str(n) for n in names)
    if len(texts) == 1:
        return texts[0]
    return f"one of {', '.join(texts)}" if texts else "none are defined"


class MissionError(Exception):
    """Bad mission input: what is wrong, where (file, 1-based line/column, key path) and what was expected.

    ``str()`` gives ``file:line:column: <key.path>: <message>; expected <expected>;
    did you mean '<suggestion>'?`` (parts that are unknown are left out) and, when
    the place is inside an included subtree, a second line naming the include.
    """

    def __init__(
        self,
        message: str,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        key_path: KeyPathLike = (),
        expected: str | None = None,
        suggestion: str | None = None,
        note: str | None = None,
    ):
        self.message = message
        self.file = None if file is None else str(file)
        self.line = line
        self.column = column
        self.key_path = tuple(key_path)
        self.expected = expected
        self.suggestion = suggestion
        self.note = note
        super().__init__(message)

    @property
    def location(self) -> str:
        """``file:line:column`` (or as much of it as is known; ``""`` if nothing is)."""
        parts = [p for p in (self.file, self.line, self.column) if p is not None]
        return ":".join(str(p) for p in parts)

    def __str__(self) -> str:
        text = ""
        if self.location:
            text += f"{self.location}: "
        if self.key_path:
            text += f"{format_key_path(self.key_path)}: "
        text += self.message
        if self.expected:
            text += f"; expected {self.expected}"
        if self.suggestion:
            text += f"; did you mean '{self.suggestion}'?"
        if self.note:
            text += f"\n  {self.note}"
        return text


def combine_errors(errors: Sequence[MissionError], limit: int = 5) -> MissionError:
    """One error for several: the error itself if there is one, else :class:`MissionErrors` of the
    first ``limit`` in file order (duplicates dropped)."""
    unique = list({(e.file, e.line, e.column, e.message): e for e in errors}.values())
    unique.sort(key=lambda e: (e.file or "", e.line or 0, e.column or 0))
    return unique[0] if len(unique) == 1 else MissionErrors(unique[:limit], total=len(unique))


class MissionErrors(MissionError):
    """Several mission errors found at once (the first few, in file order).

    Behaves as the first error (same ``file``, ``line`` … attributes) and prints
    all of them, one per line, with the number left out.
    """

    def __init__(self, errors: Sequence[MissionError], total: int | None = None):
        if not errors:
            raise ValueError("MissionErrors needs at least one error")
        self.errors = list(errors)
        self.total = max(total or 0, len(self.errors))
        first = self.errors[0]
        super().__init__(
            first.message, first.file, first.line, first.column, first.key_path,
            first.expected, first.suggestion, first.note,
        )

    def __str__(self) -> str:
        lines = [MissionError.__str__(e) for e in self.errors]
        more = self.total - len(self.errors)
        if more > 0:
            lines.append(f"… and {more} more error{'s' if more > 1 else ''}")
        return "\n".join(lines)


def check_seed(seed: object, what: str = "seed") -> int:
    """``seed`` if it is an integer >= 0 (numpy's seed sequences take no negatives); else a :class:`MissionError`."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise MissionError(f"{what} {seed!r} is not a seed", expected="an integer >= 0")
    return seed
