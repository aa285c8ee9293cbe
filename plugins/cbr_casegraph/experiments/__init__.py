"""Reproductions of section 6 of the case graph paper (Hodál & Dvořák, Figs. 2-5 and Table 1).

Four experiments, each run by ``cbr experiment NAME --size ci|full``:

``cbr-share``
    Section 6.2, Fig. 3: the share of random tasks planned by CBR against the coverage of the
    map by graph vertices.
``deviation-table``
    Section 6.4, Table 1 and Fig. 5: the hybrid planner, Dijkstra, A* and Ai* against the best
    of the four in path cost, length and turns.
``time-vs-map-size``
    Section 6.3, Fig. 4: CBR planning time with 1000, 2000 and 3000 vertices, and the
    alternative methods' times, on square maps of growing size.
``time-vs-vertices``
    Section 6.1, Fig. 2: CBR planning time against the vertex count, full against selective
    adaptation.

The paper does not describe its maps. All four use random obstacle maps (15% of the cells,
:func:`cbr_grid.generate.generate` ``"random"``) with smooth terrain risk (amount 0.5), so that a
path's cost (length times the risk factor, eq. 4) differs from its length as in the paper's
Table 1; random obstacles spread the tasks evenly, which matches the paper's "uniform coverage".
Graphs are grown by :func:`cbr_casegraph.build.grow` (Dijkstra paths of random tasks retained).
The quality test of step 7 is applied as the ``path_quality`` reviser applies it: a CBR path is
accepted when its length is at most 1.5 times the octile distance between start and goal.

The modules: :mod:`~cbr_casegraph.experiments.common` (the maps, the quality test, task drawing,
timing and the base class :class:`~cbr_casegraph.experiments.common.GridExperiment`),
:mod:`~cbr_casegraph.experiments.share` (``cbr-share``),
:mod:`~cbr_casegraph.experiments.deviation` (``deviation-table``) and
:mod:`~cbr_casegraph.experiments.timing` (``time-vs-map-size`` and ``time-vs-vertices``).
"""
