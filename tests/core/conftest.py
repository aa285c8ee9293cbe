"""Fixtures of the core tests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from cbr_experiments.tasks import TaskRunner, open_tasks


@pytest.fixture(scope="module")
def cluster() -> Iterator[TaskRunner]:
    """A LocalCluster of two worker processes, shared by the tests of this module."""
    with open_tasks("local", workers=2) as runner:
        yield runner
