"""Tests of the grid searches and planners of ``cbr_solvers``."""
