"""Tests of whole-path cases (``cbr_pathcases``) and their experiment."""
