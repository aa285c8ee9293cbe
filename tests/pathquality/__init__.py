"""Tests of path quality bounds (``cbr_pathquality``)."""
