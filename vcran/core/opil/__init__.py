"""OPIL (docs/contract.md §2, §3), the first protocol, pure: what is OPIL's and no other protocol's (docs/protocols.md).

Beside it the shared core (vcran/core: motion, stations, battery, faults, collisions, jobs, the scenario)
that every protocol uses; VDA 5050's pure modules sit beside it in vcran/core/vda5050. No protocol
imports another's (import contracts in pyproject.toml).
"""
