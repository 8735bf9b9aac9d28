"""Benchmarks (`make bench`, `boundid bench`): side-by-side timings in one run, as ratios.

Each module ``bench_<topic>.py`` here defines ``run(quick: bool = False) -> pandas.DataFrame``
(one row per case, with a ``ratio`` column against the case's reference) and ``GOALS``, a short
Markdown text stating the goals it checks. ``python -m boundid.bench`` runs them all and writes
``<out>/<topic>.csv`` and ``<out>/<topic>.md``.
"""
