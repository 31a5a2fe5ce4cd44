"""The kill-point wait of tests/test_determinism.py (its killed-run test timed out under load with a fixed
600 s deadline): a slow run that keeps writing is waited for; a stalled run or one that ended fails."""

import subprocess
import sys

import pytest
from test_determinism import _wait_for


def _writer(wd, n: int, dt: float, target: str | None) -> subprocess.Popen:
    code = (f"import time, pathlib; d = pathlib.Path({str(wd)!r}) / 'results'; d.mkdir(exist_ok=True)\n"
            f"for i in range({n}):\n    time.sleep({dt}); (d / f'f{{i}}').write_text('x')\n"
            + (f"(d / {target!r}).write_text('x')\n" if target else "") + "time.sleep(60)\n")
    return subprocess.Popen([sys.executable, "-c", code])


@pytest.mark.parametrize("case", ["progressing", "stalled", "ended"])
def test_the_wait_follows_progress_not_the_clock(tmp_path, case):
    if case == "ended":
        proc = subprocess.Popen([sys.executable, "-c", "pass"])
        proc.wait()
        with pytest.raises(AssertionError, match="ended before"):
            _wait_for([tmp_path / "results" / "done"], proc, tmp_path, stall=30)
        return
    # progressing: 8 outputs 1.5 s apart (12 s in all, longer than the 6 s stall window) then the target
    proc = _writer(tmp_path, 8 if case == "progressing" else 1, 1.5, "done" if case == "progressing" else None)
    try:
        if case == "progressing":
            _wait_for([tmp_path / "results" / "done"], proc, tmp_path, stall=6)
        else:
            with pytest.raises(AssertionError, match="no progress"):
                _wait_for([tmp_path / "results" / "done"], proc, tmp_path, stall=6)
    finally:
        proc.kill()
        proc.wait()
