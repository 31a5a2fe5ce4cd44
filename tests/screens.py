"""Issue 23's screens checked against the unscreened diagnosis: the same sweep diagnosed as it runs and with each
screen's function swapped for one that keeps everything (as before the screen), the swaps undone afterwards
(tests/test_pair_screen.py, test_modelform_screen.py, test_heldout_screen.py)."""

import contextlib
from unittest import mock

from mrhyst import diagnose as dg
from test_diagnose import FAST


def screened_and_full(sw, swaps, view=lambda d: d):
    """(screened, unscreened) diagnoses of ``sw`` at the FAST settings, each through ``view``; ``swaps``: (module,
    function name, replacement) for the unscreened one."""
    screened = view(dg.diagnose(sw, FAST))
    with contextlib.ExitStack() as stack:
        for owner, name, fn in swaps:
            stack.enter_context(mock.patch.object(owner, name, fn))
        full = view(dg.diagnose(sw, FAST))
    return screened, full
