"""Tests of cbrcore's engine, configuration, registry, plugins, hooks, runs and warm-up."""
