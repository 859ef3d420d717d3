"""Hypothesis profiles for the emulator's kernel tests.

By default every run generates 500 cases per kernel (the figure the emulator
is held to); ``MNSS_HYPOTHESIS_PROFILE=dev`` runs 50 for a quick local check.
"""

import os

from hypothesis import HealthCheck, settings

# derandomize: every run checks the same generated cases, so CI is repeatable
_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True, derandomize=True)
settings.register_profile("ci", max_examples=500, **_COMMON)
settings.register_profile("dev", max_examples=50, **_COMMON)
settings.load_profile(os.environ.get("MNSS_HYPOTHESIS_PROFILE", "ci"))
