"""Tests of the docs, their figures, the repository's promises and the architecture."""
