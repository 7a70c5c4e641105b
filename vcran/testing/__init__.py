"""Test helpers for vcran and its users (docs/fuzzing.md).

* :mod:`vcran.testing.strategies` — hypothesis strategies for every message type (the codec's fuzzing);
* :mod:`vcran.testing.model` — a reference model of RanLogic's rules, written to be obviously right;
* :mod:`vcran.testing.plans` — task plans and the deviations a real fleet manager produces;
* :mod:`vcran.testing.stateful` — a hypothesis state machine pairing RanLogic with the model;
* :mod:`vcran.testing.scripts` — strategies for whole scenarios and perturbations of a message script;
* :mod:`vcran.testing.checks` — the rules checked on a run's output folder;
* :mod:`vcran.testing.loop` — fuzzing a fleet manager: workload, stock, link and fault strategies, the loop
  properties.
"""
