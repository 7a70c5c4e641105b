"""vcran: a headless, deterministic re-implementation of the OPIL VC-RAN (see README.md)."""

__version__ = "0.1.0"
