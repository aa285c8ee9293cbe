"""The errors cbrcore raises on bad input.

Every error a user can cause derives from :class:`CbrError`; the CLI prints its message and exits
with code 2 (no traceback unless ``--traceback``). Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

_URI_PASSWORD = re.compile(r"([a-zA-Z][a-zA-Z0-9+.-]*://[^\s/:@'\"]*):[^\s@/'\"]*@")
_KEY_PASSWORD = re.compile(r"\b((?:ssl)?password)\s*=\s*(?:'(?:[^'\\]|\\.)*'?|[^\s'\"]+)",
                           re.IGNORECASE)


def without_credentials(text: str) -> str:
    """``text`` with the password of every address (``scheme://user:password@host``) and every
    ``password=`` field of a connection string shown as ``***``."""
    return _KEY_PASSWORD.sub(r"\1=***", _URI_PASSWORD.sub(r"\1:***@", text))


class CbrError(Exception):
    """A problem with the user's input, files or plugins, explained in the message.

    The message never shows a password: a value quoted from the user's input may be a
    connection string copied where it does not belong (a YAML alias of a DSN under ``seed``, a
    scheduler address with credentials), so :func:`without_credentials` masks it whoever built
    the message.
    """

    def __str__(self) -> str:
        return without_credentials(super().__str__())


class ConfigError(CbrError):
    """A configuration that cannot be used; ``problems`` holds one line per problem found."""

    def __init__(self, source: str, problems: Sequence[str]) -> None:
        self.source = source
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        noun = "problem" if len(self.problems) == 1 else "problems"
        super().__init__(f"{source}: {len(self.problems)} {noun}:\n{lines}")


class PluginError(CbrError):
    """A plugin that could not be imported, could not register, or was asked for and is missing."""


class PluginWarning(UserWarning):
    """A plugin that failed to load and was skipped while the others loaded.

    Its own category, so that an application can filter it or show it its own way: the ``cbr``
    command line prints each as one ``warning:`` line on stderr.
    """


class PhaseError(CbrError):
    """A plugin raised inside a phase of the cycle; the original exception is the ``__cause__``."""

    def __init__(self, phase: str, plugin: str, error: BaseException) -> None:
        self.phase = phase
        self.plugin = plugin
        super().__init__(
            f"plugin {plugin!r} failed in phase {phase!r}: {type(error).__name__}: {error}"
        )


class CaseBaseError(CbrError):
    """A case base that is missing, corrupt, locked, foreign or of another schema version, or an
    exported case base document that cannot be read."""


class CaseBaseLocked(CaseBaseError):
    """A case base whose write lock another process held for longer than the store waits for it
    (its ``busy_timeout``)."""


class UnusableCaseBase(CaseBaseError):
    """A case base that exists but cannot be used, found when its store opens it.

    It is damaged, belongs to another program, or has a schema version this cbrcore does not
    read. A store refuses it without writing to it; ``cbr casebase check`` reports it as the case
    base's problem.
    """
