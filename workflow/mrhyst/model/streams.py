"""Random streams keyed by NAME, never by position (issue 22).

A registry entry (an effect, a model-form candidate, a blind class) that draws random numbers draws them from
its own stream: ``numpy.random.SeedSequence`` of the caller's seed, a purpose tag and a stable 64-bit key of the
entry's name (:func:`name_key`: BLAKE2b of its UTF-8 bytes, the same on every machine and Python run, unlike
``hash()``). Registering one more entry, or reordering them, then leaves every other entry's draws as they
were."""

from __future__ import annotations

import hashlib

import numpy as np


def name_key(name: str) -> int:
    """A stable 64-bit integer of ``name``: the first 8 bytes of its BLAKE2b digest, little-endian."""
    return int.from_bytes(hashlib.blake2b(str(name).encode("utf-8"), digest_size=8).digest(), "little")


def stream(seed: int, tag: int, name: str) -> np.random.Generator:
    """The generator of entry ``name`` for purpose ``tag`` under ``seed``: independent of every other name."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(tag), name_key(name)]))
