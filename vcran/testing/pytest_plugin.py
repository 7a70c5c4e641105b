"""vcran's hypothesis profiles as a pytest plugin (entry point ``pytest11: vcran``; docs/fuzzing.md).

pytest loads this module wherever vcran is installed, and it changes nothing until a test run opts in: it
only registers three hypothesis profiles, which a run selects with hypothesis' own option::

    pytest --hypothesis-profile=vcran         # the everyday profile (vcran's own suite uses it)
    pytest --hypothesis-profile=vcran-deep    # a long campaign
    pytest --hypothesis-profile=vcran-nightly # a scheduled job whose log alone reproduces a failure

or for good with ``addopts = "--hypothesis-profile=vcran"`` in the project's pytest configuration.

Why profiles at all: a simulated run's wall time depends on the machine and its load, never its outcome, so
hypothesis' default per-example deadline (200 ms) and its ``too_slow`` health check fail good tests on a
busy or fresh machine (the first text draw builds Unicode tables). The profiles turn them off.

The profiles are registered when pytest imports this module, before any plugin's ``pytest_configure``
(hypothesis loads the chosen profile there). Without hypothesis (vcran installed without its ``fuzz`` extra)
the plugin registers nothing and stays out of the way.
"""

from __future__ import annotations

try:
    from hypothesis import HealthCheck, settings
except ModuleNotFoundError:  # pragma: no cover - exercised by the wheel test's plain install
    settings = None  # type: ignore[misc,assignment]

#: Profile name -> (examples per test, steps per state machine run).
PROFILES: dict[str, tuple[int, int]] = {
    "vcran": (100, 50),
    "vcran-deep": (5_000, 120),
    "vcran-nightly": (20_000, 200),
}
#: Profiles whose failures print a ``@reproduce_failure`` blob: an unattended job has no example database
#: to replay from, only its log.
PRINT_BLOB = frozenset({"vcran-nightly"})


def register() -> None:
    """Register the profiles (idempotent); :data:`PROFILES` says how large each is."""
    if settings is None:
        return
    for name, (examples, steps) in PROFILES.items():
        settings.register_profile(
            name, deadline=None, suppress_health_check=[HealthCheck.too_slow],
            max_examples=examples, stateful_step_count=steps, print_blob=name in PRINT_BLOB,
        )


register()
