"""The errors cbrcore raises on bad input.

Every error a user can cause derives from :class:`CbrError`; the CLI prints its message and exits
with code 2 (no traceback unless ``--traceback``). Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

from collections.abc import Sequence


class CbrError(Exception):
    """A problem with the user's input, files or plugins, explained in the message."""


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
