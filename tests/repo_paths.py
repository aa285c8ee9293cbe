"""Where the repository and the test data are, for test modules at any depth of ``tests/``."""

from __future__ import annotations

from pathlib import Path

# the repository's root folder: tests/ is directly below it
ROOT = Path(__file__).resolve().parent.parent
# files the tests read: Moving AI maps, Nav2 maps and graphs, case bases of older schemas
DATA = ROOT / "tests" / "data"
