"""VDA 5050's SimPy glue (docs/protocols.md, issue 31): the pure Vehicle around the shared robot body."""
