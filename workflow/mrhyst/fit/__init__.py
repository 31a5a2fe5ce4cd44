"""Fitting stack: solvers that know nothing of the domain (scipy-like signatures).

``LMResult`` and ``least_squares_batch`` (mrhyst.fit.lm, the batched Levenberg-Marquardt of the diagnosis) are
imported on first use: a J-A fit (fit.identify, scipy's least_squares) starts without compiling-side imports it
does not use (issue 26)."""

__all__ = ["LMResult", "least_squares_batch"]


def __getattr__(name: str):
    if name in __all__:
        from mrhyst.fit import lm

        return getattr(lm, name)
    raise AttributeError(f"module 'mrhyst.fit' has no attribute {name!r}")
