"""Reproductions of 002 (Ros et al.) and its future work, run by ``cbr experiment NAME``.

``landmark-scenarios``
    Section 4, Figures 6 and 7: the two scenarios with and without the CBR agent
    (:mod:`~cbr_landmarks.experiments.scenarios`, :mod:`~cbr_landmarks.experiments.figure7`),
    and scenario 2 off the paper's pose (:mod:`~cbr_landmarks.experiments.robustness`).
``landmark-learning``
    Section 5's stated goal: situations learned on worlds of six shapes reused on unseen ones,
    transfer and repetition apart (:mod:`~cbr_landmarks.experiments.learning`).

The robots compared and how one robot's trials run are in
:mod:`~cbr_landmarks.experiments.common`.
"""
