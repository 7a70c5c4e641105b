"""``vcran sweep``: many variants and seeds of one scenario into one KPI table (docs/contract.md §10, docs/sweeps.md).

The layers of a sweep, each usable alone: :mod:`~vcran.sweep.spec` reads a sweep file into runs,
:mod:`~vcran.sweep.overrides` applies a run's dotted paths to the scenario, :mod:`~vcran.sweep.worker`
runs one of them as a pure function of plain data.
"""
