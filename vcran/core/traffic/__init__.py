"""Traffic (docs/contract.md §12): roadmaps, safety fields that stop robots, blocking and deadlocks, routing. Pure.

Shared by both protocols (OPIL and VDA 5050): nothing here knows a message or a process. One concept a
module:

- :mod:`~vcran.core.traffic.roadmap`: nodes and edges, and the one check of a roadmap (and of the
  stations' docks on it);
- :mod:`~vcran.core.traffic.paths`: shortest routes on a roadmap (by length, or by time under speed
  limits), with a documented order between routes of equal cost;
- :mod:`~vcran.core.traffic.fields`: a robot's protective field (its length at a speed, its rectangle
  ahead of the footprint) and the field's track along a leg;
- :mod:`~vcran.core.traffic.settings`: a scenario's ``[traffic]``: the fleet's field, the deadlock bound, what a
  deadlock does;
- :mod:`~vcran.core.traffic.braking`: braking to a stop from any instant of a leg, and the rest of the leg
  driven on from rest;
- :mod:`~vcran.core.traffic.intrusion`: the first instant another robot's footprint enters a field, or
  leaves it, along both tracks (numpy; the sampling of :mod:`vcran.core.overlap`);
- :mod:`~vcran.core.traffic.watch`: which robot's field holds which others and when that changes next,
  for a whole fleet at near-linear cost (the grid of :mod:`vcran.core.collisions`);
- :mod:`~vcran.core.traffic.deadlock`: cycles of robots stopped on one another, and robots blocked longer
  than a bound;
- :mod:`~vcran.core.traffic.control`: the fleet's state machine (brake, wait, drive on; ``blocked``,
  ``unblocked``, ``deadlock``) with inputs carrying ``now`` and effects as data: what the SimPy body drives;
- :mod:`~vcran.core.traffic.reservations`: node reservations for a fleet manager's robots, so that they
  neither meet nor deadlock on a roadmap.

docs/robots.md ("Traffic") describes the model and derives the ``corridor`` scenario's instants by hand.
"""
