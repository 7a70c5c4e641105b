"""OPIL's SimPy glue (docs/protocols.md): the RAN and RanLogic's process around the shared body, OPIL's
publications, and OPIL's closed loop. It imports the shared simulation (vcran/sim) and OPIL's pure core
(vcran/core/opil); nothing shared imports it.
"""
