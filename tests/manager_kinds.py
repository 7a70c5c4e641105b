"""Fleet managers for tests/test_manager_options.py (issue 29 item 9), in a module of their own so that the
test and vcran's ``module:Class`` import find the same class objects."""

from __future__ import annotations

from vcran.managers import Dispatcher


class Tuned(Dispatcher):
    """The scenario's own class: it cannot be built without the option the scenario gives it."""

    def __init__(self, *, tries: int) -> None:
        super().__init__(max_tries=tries)


class Plain(Dispatcher):
    """Another class (a subclass of the Dispatcher, not of Tuned), which takes no options at all."""

    def __init__(self) -> None:
        super().__init__()


Alias = Tuned  # another path to the scenario's own class: ``HERE:Alias`` is the same class object
