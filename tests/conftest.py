"""Suite-wide test settings.

Hypothesis runs without a per-example deadline and without the too_slow health check: CI tests a fresh
clone (no .hypothesis cache, so the first text draw builds Unicode tables) on a shared machine whose
load varies, and neither timing says anything about vcran's behaviour. Example counts stay at the default.
"""

from hypothesis import HealthCheck, settings

settings.register_profile("vcran", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("vcran")
