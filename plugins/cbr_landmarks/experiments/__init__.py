"""Reproductions of 002 (Ros et al.) and its future work, run by ``cbr experiment NAME``.

``landmark-scenarios``
    Section 4, Figures 6 and 7: the two scenarios with and without the CBR agent
    (:mod:`~cbr_landmarks.experiments.scenarios`).
``landmark-learning``
    Section 5's stated goal: situations learned on some semi-structured worlds reused on unseen
    ones (:mod:`~cbr_landmarks.experiments.learning`).

The robots compared and how one robot's trials run are in
:mod:`~cbr_landmarks.experiments.common`.
"""
