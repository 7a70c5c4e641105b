"""VDA 5050 (docs/contract.md §11), pure: the messages of 2.0.0 and 2.1.0, their codec and schema validation, and the
vehicle, a state machine beside OPIL's RanLogic (docs/vda5050.md).

Nothing here imports SimPy, an MQTT client or an HTTP client, reads a clock or writes a file; the only
file read is the package's own copy of the official JSON schemas (:mod:`vcran.core.vda5050.validation`).
"""
