"""Text from outside made printable: the one rule for whatever a vehicle (or any peer)
sends that an operator will read.

A STATUSTEXT is 50 bytes that anyone on the link can fill. Shown as it came, an escape
sequence clears or rewrites the operator's terminal, a bidirectional override turns a
warning around, and a line break forges a line of its own. Every character Unicode
calls a control, a format character, a surrogate, private or unassigned (categories
``C*``) becomes U+FFFD, and whitespace runs become one space. Markup (Rich's ``[...]``)
is not this module's business: the display shows such text as plain text.
"""

from __future__ import annotations

import unicodedata

#: What stands in for a character that must not reach a terminal.
REPLACEMENT = "\ufffd"


def printable(text: str, limit: int = 200) -> str:
    """``text`` with every non-printable character replaced, whitespace runs as one space,
    cut to ``limit`` characters."""
    out: list[str] = []
    space = False
    for char in text[: limit * 2]:
        if char.isspace():
            space = bool(out)
            continue
        if space:
            out.append(" ")
            space = False
        out.append(REPLACEMENT if unicodedata.category(char).startswith("C") else char)
    return "".join(out)[:limit]


def is_printable(text: str) -> bool:
    """Whether ``text`` holds no character ``printable`` would replace (spaces aside)."""
    return not any(
        unicodedata.category(char).startswith("C") or (char.isspace() and char != " ")
        for char in text
    )
