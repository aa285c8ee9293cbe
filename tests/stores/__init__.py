"""Tests of the stores of ``cbr_stores``: SQLite and PostgreSQL."""
