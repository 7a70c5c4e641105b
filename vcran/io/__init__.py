"""The file edges (README "Layout", layer 3): scenario files, traces and run folders, terminal output.

Reading TOML into a :class:`~vcran.core.scenario.Scenario` and writing it back, the trace and telemetry
files a run records, replay verification, generated scenarios, progress lines. Built on the pure core;
the SimPy model never imports from here (an import contract checks it).
"""
