"""Test helpers for VDA 5050 vehicles and masters (docs/contract.md §11, docs/vda5050.md).

* :mod:`vcran.testing.vda5050.strategies` — hypothesis strategies for every message kind, in 2.0.0 and 2.1.0;
* :mod:`vcran.testing.vda5050.plans` — orders a vehicle can drive, and the updates, cancels and pauses
  a master sends them;
* :mod:`vcran.testing.vda5050.model` — a reference model of the vehicle's acceptance rules (§6.6);
* :mod:`vcran.testing.vda5050.stateful` — a hypothesis state machine pairing the vehicle with the model;
* :mod:`vcran.testing.vda5050.yard` — a master and a scenario's vehicles in simulated time, without SimPy;
* :mod:`vcran.testing.vda5050.scripted` — a VDA 5050 scenario's script and its stations' production there;
* :mod:`vcran.testing.vda5050.fuzz` and :mod:`vcran.testing.vda5050.checks` — the perturbations of a script
  ``vcran fuzz`` draws and the properties it checks on each run (run by :mod:`vcran.testing.vda5050_runs`).
"""
