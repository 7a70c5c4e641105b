"""The ``fuzz`` extra: the hypothesis-based helpers say which install they need instead of failing with
Python's bare ``No module named 'hypothesis'`` (vcran itself runs without it)."""

from __future__ import annotations


def require_hypothesis(module: str) -> None:
    """Raise ModuleNotFoundError naming ``module`` and the extra when hypothesis is not installed."""
    try:
        import hypothesis  # noqa: F401
    except ModuleNotFoundError:
        raise ModuleNotFoundError(f"{module} needs hypothesis, which the 'fuzz' extra installs: "
                                  "pip install 'vcran[fuzz]'", name="hypothesis") from None
