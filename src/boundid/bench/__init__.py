"""Benchmarks (`make bench`, `boundid bench`): side-by-side timings in one run, as ratios.

Each module ``bench_<topic>.py`` here defines ``run(quick: bool = False) -> pandas.DataFrame``
(one row per case, with a ``ratio`` column against the case's reference), ``GOALS``, a short
text stating its goals for readers, and ``GOAL_CHECKS``, the same goals as
:class:`boundid.bench.goals.Goal` records that the benchmark page judges on the CSV.
``python -m boundid.bench`` runs them all and writes ``<out>/<topic>.csv``, ``.json`` (the
machine) and ``.md``, then ``<out>/index.html`` (every goal met or missed); ``--page-only``
rebuilds the page from those files.
"""
