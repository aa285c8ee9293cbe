"""Tests of the grid family (``cbr_grid``): grids, costs, formats, generators, trips."""
