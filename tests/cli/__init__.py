"""Tests of the ``cbr`` command line: commands, bad inputs, start-up, completion."""
