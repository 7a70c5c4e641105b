"""The pure core (README "Layout", layer 1): no SimPy, no httpx, no clock, no files, no global random.

RanLogic is a state machine fed with timestamped inputs that returns effects; the message types, the id
mapping, the NGSI/OPIL codec, leg kinematics, stations and the scenario data model are plain data and
functions. Everything above (the SimPy model, files, transports, commands) may import from here; nothing
here imports from them (the import contracts in pyproject.toml check it in CI).
"""
