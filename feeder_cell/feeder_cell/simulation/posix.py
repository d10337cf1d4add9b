r"""POSIX Extended regular expressions (EntityFilters.filter) translated to Python's ``re``.

The standard names POSIX Extended syntax (EntityFilters.msg; IEEE Std 1003.1, XBD chapter 9). Python's
``re`` shares ERE's operators (``| * + ? {m,n} ( ) . ^ $``) but not its bracket expressions, so those are
translated, and what ERE does not define is refused rather than read in Python's sense:

- ``[...]``: in ERE a backslash is an ordinary character, ``]`` first is literal, ``-`` first or last is
  literal, ``[:class:]`` is a character class, ``[=c=]`` and ``[.c.]`` a single character; every
  character is emitted escaped, so no Python set operation (``[[``, ``&&``, ``--``, ``||``, ``~~``, which
  Python warns about with a FutureWarning) can arise.
- the twelve classes in the POSIX locale (ASCII): ``CLASSES``.
- outside brackets, ``\`` followed by a letter or digit (Python's ``\d``, ``\w``, back-references) and
  ``(?`` (Python's extensions) are not ERE: refused, naming the position.

Whether a name matches does not depend on POSIX's leftmost-longest rule (only which substring does), so
``re.search`` of the translation selects exactly the names ``regexec`` would (REG_EXTENDED, no flags).
"""

from __future__ import annotations

import re

__all__ = ["CLASSES", "PosixError", "translate", "compile_ere"]

_PUNCT = "!\"#$%&'()*+,-./:;<=>?@[\\]^_`{|}~"
# The POSIX locale's character classes (XBD 7.3.1), as the characters each holds.
CLASSES: dict[str, str] = {
    "alpha": "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz",
    "digit": "0123456789",
    "alnum": "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz",
    "upper": "ABCDEFGHIJKLMNOPQRSTUVWXYZ",
    "lower": "abcdefghijklmnopqrstuvwxyz",
    "space": " \t\n\r\f\v",
    "blank": " \t",
    "punct": _PUNCT,
    "print": "".join(chr(c) for c in range(0x20, 0x7F)),
    "graph": "".join(chr(c) for c in range(0x21, 0x7F)),
    "cntrl": "".join(chr(c) for c in range(0x00, 0x20)) + "\x7f",
    "xdigit": "0123456789ABCDEFabcdef",
}


class PosixError(ValueError):
    """A filter that is no POSIX Extended regular expression (the message names the position)."""


def _char(c: str) -> str:
    # Inside a Python class every non-alphanumeric character escaped is itself (re's rule).
    return c if c.isalnum() else "\\" + c


def _bracket(pattern: str, start: int) -> tuple[str, int]:
    """Translate the bracket expression opening at ``start``; return it and the index after its ``]``."""
    i = start + 1
    negate = i < len(pattern) and pattern[i] == "^"
    if negate:
        i += 1
    items: list[str] = []
    first = True
    while True:
        if i >= len(pattern):
            raise PosixError(f"bracket expression at {start} is not closed")
        c = pattern[i]
        if c == "]" and not first:
            i += 1
            break
        first = False
        if c == "[" and i + 1 < len(pattern) and pattern[i + 1] in ":=.":
            kind = pattern[i + 1]
            end = pattern.find(kind + "]", i + 2)
            if end < 0:
                raise PosixError(f"[{kind} at {i} is not closed by {kind}]")
            name = pattern[i + 2 : end]
            i = end + 2
            if kind == ":":
                if name not in CLASSES:
                    raise PosixError(f"unknown character class [:{name}:] at {start}")
                items.append("".join(_char(x) for x in CLASSES[name]))
                continue
            if len(name) != 1:
                raise PosixError(f"[{kind}{name}{kind}] at {start}: only single characters are collated")
            low = name
        else:
            low = c
            i += 1
        # A range: low '-' high, unless '-' is the last character before ']'.
        if i + 1 < len(pattern) and pattern[i] == "-" and pattern[i + 1] != "]":
            high = pattern[i + 1]
            i += 2
            if high == "[" and i < len(pattern) and pattern[i] in ".=":
                kind = pattern[i]
                end = pattern.find(kind + "]", i + 1)
                if end < 0 or end != i + 2:
                    raise PosixError(f"range end at {i - 1}: a single collating element")
                high, i = pattern[i + 1], end + 2
            if ord(high) < ord(low):
                raise PosixError(f"range {low}-{high} at {start} is out of order")
            items.append(f"{_char(low)}-{_char(high)}")
        else:
            items.append(_char(low))
    return "[" + ("^" if negate else "") + "".join(items) + "]", i


def translate(pattern: str) -> str:
    """Return the Python ``re`` pattern selecting what the POSIX Extended ``pattern`` does."""
    out: list[str] = []
    i = 0
    while i < len(pattern):
        c = pattern[i]
        if c == "[":
            text, i = _bracket(pattern, i)
            out.append(text)
            continue
        if c == "\\":
            if i + 1 >= len(pattern):
                raise PosixError(f"trailing backslash at {i}")
            following = pattern[i + 1]
            if following.isalnum():
                raise PosixError(
                    f"\\{following} at {i} is not POSIX Extended (escape only special characters)"
                )
            out.append("\\" + following)
            i += 2
            continue
        if c == "(" and pattern.startswith("(?", i):
            raise PosixError(f"'(?' at {i} is not POSIX Extended ('?' repeats nothing there)")
        out.append(c)
        i += 1
    return "".join(out)


def compile_ere(pattern: str) -> re.Pattern[str]:
    """Compile a POSIX Extended regular expression; PosixError names what is wrong."""
    try:
        return re.compile(translate(pattern))
    except re.error as error:
        raise PosixError(str(error)) from None
