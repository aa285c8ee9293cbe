"""Names a user gives things in files (cases, places, landmarks): text that prints as itself.

A name with a control character (a NUL byte, a line break, an escape sequence) would be cut
short by C libraries, break the line-per-record output of the command line, or move the cursor
of the terminal that shows it; such a name is refused where it is read.
"""

from __future__ import annotations

import unicodedata


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a name, or None: the first control character in it, by position
    (from 1) and code point, never the name itself."""
    for position, char in enumerate(name, 1):
        if unicodedata.category(char) == "Cc":
            return (f"a name holds no control characters, got U+{ord(char):04X} at character "
                    f"{position}")
    return None
