"""Subcommands of ``vcran`` (see :mod:`vcran.cli`)."""
