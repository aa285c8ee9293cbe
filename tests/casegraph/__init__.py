"""Tests of the case graph planner (``cbr_casegraph``) and its experiments."""
