"""Tests of RUPART's behaviors (``cbr_behaviors``)."""
