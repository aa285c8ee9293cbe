"""Tests of landmark-graph situations (``cbr_landmarks``) and their experiments."""
