"""The SimPy model: thin processes around the pure core (DESIGN.md, layer 2)."""
