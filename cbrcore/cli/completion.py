"""Shell completion of the names ``cbr`` takes: ``--set`` keys and components.

Each function is a typer ``autocompletion`` callback: it gets the word being completed and
returns ``(value, help)`` pairs, read from the registry of the loaded plugins, so a plugin's
components complete as the built-in ones do. ``cbr --install-completion``
installs the shell's side.

Bash breaks a line into words at the characters of its ``COMP_WORDBREAKS``, ``=`` among them, so
``--set retrieve=ne`` reaches the completer as the words ``--set``, ``retrieve``, ``=``, ``ne``
and no parameter claims the last one. :func:`split_option_value` recognises that form, and the
commands (:class:`cbrcore.cli.conventions.CbrCommand`) complete the option's ``KEY=VALUE`` word
whole, offering bash the value part alone, which is all bash replaces. Zsh and fish keep the
word whole and need none of this.
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Mapping

from cbrcore.plugins import current
from cbrcore.registry import LIST_SLOTS, SINGLE_SLOTS, Registry


def _slots(registry: Registry) -> dict[str, str]:
    """Every component slot of a configuration and the kind it takes."""
    return {**SINGLE_SLOTS, **LIST_SLOTS,
            **{name: slot.kind for name, slot in registry.slots.items()}}


def settings(incomplete: str) -> list[tuple[str, str]]:
    """``--set`` values: a top-level key (``retrieve=``) while the key is being written, then
    the registered components of the slot's kind (``retrieve=nearest``); ``SLOT.use=`` takes
    them too. Candidates are whole ``KEY=VALUE`` words; in bash, which splits the word at its
    ``=``, the command offers their value part (see :func:`split_option_value`)."""
    registry = current().registry
    slots = _slots(registry)
    key, sep, value = incomplete.partition("=")
    if not sep:
        keys = [("seed=", "the seed of every random choice"),
                *((f"{slot}=", f"a {kind}") for slot, kind in slots.items())]
        return sorted(item for item in keys if item[0].startswith(incomplete))
    kind = slots.get(key.removesuffix(".use"))
    if kind is None or (key.endswith(".use") and key.removesuffix(".use") in LIST_SLOTS):
        return []
    return [(f"{key}={c.name}", c.summary) for c in registry
            if c.kind == kind and c.name.startswith(value)]


def _shell_words(line: str) -> list[str]:
    """The words of a command line as the completion machinery splits ``COMP_WORDS``; an
    unclosed quote ends the last word rather than failing, the line being half typed."""
    lexer = shlex.shlex(line, posix=True)
    lexer.whitespace_split = True
    lexer.commenters = ""
    words: list[str] = []
    try:
        words.extend(lexer)
    except ValueError:
        words.append(lexer.token)
    return words


def split_option_value(prog_name: str,
                       environ: Mapping[str, str] = os.environ) -> tuple[str, str] | None:
    """The option and its ``KEY=VALUE`` word as typed so far, when bash asks to complete the
    value of ``OPTION KEY=VALUE`` after splitting the word at its ``=``: the cursor on the
    ``=`` word (nothing typed after it) or on the word after it. None for any other request,
    and for other shells.

    ``prog_name`` names the program whose completion variable (``_CBR_COMPLETE`` for ``cbr``)
    says which shell asks; bash passes the words in ``COMP_WORDS`` and the cursor's word in
    ``COMP_CWORD``.
    """
    if environ.get(f"_{prog_name.replace('-', '_').upper()}_COMPLETE") != "complete_bash":
        return None
    try:
        words = _shell_words(environ["COMP_WORDS"])
        cword = int(environ["COMP_CWORD"])
    except (KeyError, ValueError):
        return None
    before, current_word = words[:cword], words[cword] if cword < len(words) else ""
    if current_word == "=":
        before, value = [*before, "="], ""
    elif current_word:  # empty: a space after the '=' began a word of its own
        value = current_word
    else:
        return None
    if len(before) < 3 or before[-1] != "=":
        return None
    option, key = before[-3], before[-2]
    if not option.startswith("-") or key.startswith("-") or key == "=":
        return None
    return option, f"{key}={value}"
