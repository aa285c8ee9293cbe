"""Tests of the case base protocol (``cbrcore.casebase``): stores, exchange, worlds, damage."""
