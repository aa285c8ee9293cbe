"""Tests of nonholonomic planning (``cbr_kinematics``)."""
