"""Fitting stack: solvers that know nothing of the domain (scipy-like signatures)."""

from mrhyst.fit.lm import LMResult, least_squares_batch

__all__ = ["LMResult", "least_squares_batch"]
