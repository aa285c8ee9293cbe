"""Tests of the 2D world simulator (``cbr_world2d``)."""
