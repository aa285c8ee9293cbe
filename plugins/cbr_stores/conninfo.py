"""PostgreSQL connection strings (DSNs) shown without their secrets.

A DSN may hold a password, and a password typed by mistake into another of its fields (an
``sslmode``, a ``port``, ``options``) is as secret. What cbrcore writes or prints of a DSN keeps
its shape and the fields that say where the case base is, :data:`SHOWN_FIELDS`; every other
field's value becomes :data:`MASK`::

    postgresql://robot:hunter2@db:5433/cases?sslmode=require
    -> postgresql://robot:***@db:5433/cases?sslmode=***
    host=db user=robot password=hunter2 sslmode=require
    -> user=robot password=*** host=db sslmode=***

(the fields of the ``key=value`` form in libpq's order).

An error about a DSN (one libpq cannot read, a value it refuses, a connection that fails) shows
no value at all: it names the fields the DSN gives and keeps of libpq's message only the words
that are not quoted values. psycopg, which reads DSNs, is imported when needed: without it a DSN
shows as :data:`MASK` whole.
"""

from __future__ import annotations

import functools
import re
import urllib.parse

from cbrcore.errors import CaseBaseError

MASK = "***"
"""What stands for a value that is not shown."""

SHOWN_FIELDS = ("host", "hostaddr", "port", "dbname", "user")
"""The fields of a DSN whose values are shown outside error messages: where the case base is."""

_URI = re.compile(r"postgres(?:ql)?://", re.IGNORECASE)
_NAMING = ("invalid connection option ", "invalid URI query parameter: ")
"""What libpq writes before the quoted name of a field it does not know."""
_QUOTED = re.compile(r"\"([^\"]*)\"|'([^']*)'")

EXPECTED = ("a PostgreSQL connection string ('host=db dbname=cases') or URI "
            "('postgresql://user@db/cases')")


@functools.cache
def _keywords() -> frozenset[str]:
    """The names of the fields libpq knows."""
    from psycopg import pq

    return frozenset(d.keyword.decode() for d in pq.Conninfo.get_defaults())


def _fields(dsn: str) -> dict[str, str]:
    """The fields ``dsn`` gives, by name; ProgrammingError when libpq cannot read it."""
    from psycopg.conninfo import conninfo_to_dict

    return {key: str(value) for key, value in conninfo_to_dict(dsn).items()
            if value is not None}


def _readable(dsn: str) -> dict[str, str] | None:
    """The fields ``dsn`` gives, by name; None when psycopg is missing or libpq cannot read
    ``dsn``."""
    try:
        import psycopg
    except ImportError:
        return None
    try:
        return _fields(dsn)
    except psycopg.Error:
        return None


def fields(dsn: str) -> dict[str, str]:
    """The fields ``dsn`` gives, by name.

    A DSN libpq cannot read gives a CaseBaseError saying what was expected and why libpq
    refused it, without any value of the DSN.
    """
    import psycopg

    try:
        return _fields(dsn)
    except psycopg.ProgrammingError as exc:
        raise CaseBaseError(f"casebase dsn: not {EXPECTED}: {_masked_text(str(exc), {})}"
                            ) from None


def masked_dsn(dsn: str) -> str:
    """``dsn`` in its own form (URI or ``key=value`` pairs) with every value but those of
    :data:`SHOWN_FIELDS` replaced by :data:`MASK`; :data:`MASK` alone for a DSN that cannot be
    read, or when psycopg is missing."""
    if not dsn.strip():
        return dsn
    given = _readable(dsn)
    if given is None:
        return MASK
    shown = {key: value if key in SHOWN_FIELDS else MASK for key, value in given.items()}
    if _URI.match(dsn.lstrip()):
        return _uri(dsn.lstrip().split("://", 1)[0], shown)
    return " ".join(f"{key}={_quoted(value)}" for key, value in shown.items())


def _quoted(value: str) -> str:
    if value and not re.search(r"[\s'\\]", value):
        return value
    escaped = value.replace("\\", "\\\\").replace("'", "\\'")
    return f"'{escaped}'"


def _uri(scheme: str, shown: dict[str, str]) -> str:
    quote = functools.partial(urllib.parse.quote, safe="")
    rest = dict(shown)
    user, password = rest.pop("user", None), rest.pop("password", None)
    credentials = "" if user is None and password is None else (
        f"{quote(user or '')}{'' if password is None else ':' + password}@")
    location = ""
    # a socket folder or a list of servers stays a query parameter, as libpq reads it
    if not any(mark in rest.get("host", "") + rest.get("port", "") for mark in "/,"):
        host, port = rest.pop("host", ""), rest.pop("port", "")
        location = (f"[{host}]" if ":" in host else host) + (f":{port}" if port else "")
    database = quote(rest.pop("dbname", ""))
    query = "&".join(f"{quote(key)}={value if value == MASK else quote(value)}"
                     for key, value in rest.items())
    return f"{scheme}://{credentials}{location}/{database}{'?' + query if query else ''}"


def scrubbed(message: str, dsn: str) -> str:
    """libpq's or psycopg's ``message`` about ``dsn`` without any value that may be secret:
    every quoted text that is not a field name, and every value ``dsn`` gives, become
    :data:`MASK`."""
    # the quoted texts are masked even when the DSN cannot be read
    return _masked_text(message, _readable(dsn) or {})


def _masked_text(message: str, given: dict[str, str]) -> str:
    try:
        names = _keywords()
    except ImportError:
        names = frozenset()

    def shown(quote: re.Match[str]) -> str:
        text = quote[1] if quote[1] is not None else quote[2]
        # an unknown field's name, as libpq names it, helps find a misspelt one
        named = text in names or text == "=" or quote.string[:quote.start()].endswith(
            _NAMING)
        return quote[0] if named else f'"{MASK}"'

    text = _QUOTED.sub(shown, message.strip())
    # the longest first: a value may hold a shorter one
    for value in sorted({v for v in given.values() if v.strip()}, key=len, reverse=True):
        text = re.sub(rf"(?<!\w){re.escape(value)}(?!\w)", MASK, text)
    return text


def connection_label(dsn: str, schema: str) -> str:
    """The case base ``dsn`` and ``schema`` name, as an error about the connection shows it:
    the fields given but none of their values."""
    if not dsn.strip():
        return (f"schema {schema} on the server the PG* environment variables name "
                "(values not shown)")
    names = list(_readable(dsn) or {})
    given = f" with {', '.join(names)}" if names else ""
    return f"schema {schema} on the server of casebase dsn{given} (values not shown)"
