"""The SimPy model: thin processes around the pure core (README "Layout", layer 2).

The processes wait on stores and timeouts, hand what arrives to the core and carry out the effects it
returns; they make no decisions. They import the core only: never a transport implementation, a file
module, a command or a report (the import contracts in pyproject.toml check it in CI). The modules here are
shared by every protocol; a protocol's glue lives in its own package (``opil``; docs/protocols.md).
"""
