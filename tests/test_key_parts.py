"""The blind key in parts (config blind.key_jobs; rules blind_draw -> blind_generate): every class drawn once, in
whichever part, gives exactly the cases and the key of one job, and the parts need no diagnosis either."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mrhyst import blind
from mrhyst.blind import cases
from mrhyst.data.io import InputError
from workflow_util import ROOT

CLASSES = ["none", "hall_offset", "thermal_drift", "hall_offset+eddy_lag", "preisach"]


@pytest.fixture(scope="module")
def small(config):
    return dict(config["blind"], n_per_class=1, counts={}, classes=CLASSES,
                reference=dict(config["blind"]["reference"], max_nfev=60))


def test_parts_hold_every_class_once():
    cfg = {"classes": [f"c{i}" for i in range(7)], "n_per_class": 1}
    cfg["classes"][3] = "none"  # any names: counts() takes the config's
    parts = cases.key_parts(cfg, 3)
    assert parts == [["c0", "none", "c6"], ["c1", "c4"], ["c2", "c5"]]
    assert cases.key_parts(cfg, 50) == [[c] for c in cfg["classes"]]  # at most one job per class
    assert cases.key_parts(cfg, 1) == [cfg["classes"]]


def _fake(code_out: dict) -> str:
    return ("import sys, json, runpy; sys.modules['mrhyst.diagnose'] = None\n"
            "from types import SimpleNamespace as S\n"
            f"o = json.loads({json.dumps(json.dumps(code_out))})\n"
            "fake = S(input=S(**o['input']), output=S(**o['output']), log=[o['log']], wildcards=S(**o['wildcards']),"
            " params=S(config={'blind': o['cfg']}, key_jobs=o['jobs']), threads=1)\n"
            "if o['output'].get('key') is None: fake.output = [o['output']['part']]\n"
            "runpy.run_path(sys.argv[1], init_globals={'snakemake': fake})\n")


def _run(script: str, spec: dict):
    p = subprocess.run([sys.executable, "-c", _fake(spec), str(ROOT / "workflow/scripts" / script)],
                       capture_output=True, text=True, env=dict(os.environ))
    assert p.returncode == 0, p.stderr[-2000:]


def test_parts_give_the_bytes_of_one_job_without_the_diagnosis(small, tmp_path):
    """The rule scripts, as the workflow runs them, with mrhyst.diagnose unimportable (issue 11 point 5): two
    blind_draw parts, then blind_generate from them; against blind.generate in one process."""
    one = tmp_path / "one"
    blind.generate(small, one / "cases", one / "key.json")
    two = tmp_path / "two"
    parts = [str(two / f"part_{i}.json") for i in range(2)]
    for i, part in enumerate(parts):
        _run("blind_draw.py", {"input": {}, "output": {"part": part}, "log": str(two / f"draw_{i}.log"),
                               "wildcards": {"part": str(i)}, "cfg": small, "jobs": 2})
    _run("blind_generate.py", {"input": {"parts": parts}, "output": {"csv": [str(two / "cases" / "case_000.csv")],
                                                                     "key": str(two / "key.json")},
                               "log": str(two / "gen.log"), "wildcards": {}, "cfg": small, "jobs": 2})
    drawn = [json.loads(Path(p).read_text())["classes"] for p in parts]
    assert sorted(sum(drawn, [])) == sorted(CLASSES) and all(drawn)
    names = sorted(p.name for p in (one / "cases").iterdir())
    assert names == sorted(p.name for p in (two / "cases").iterdir()) and len(names) == 2 * len(CLASSES)
    for n in names:
        assert (two / "cases" / n).read_bytes() == (one / "cases" / n).read_bytes(), n
    assert (two / "key.json").read_bytes() == (one / "key.json").read_bytes()


def test_a_missing_class_is_one_clear_error(small, tmp_path):
    cases.write_part(small, ["none"], tmp_path / "p.json")
    with pytest.raises(InputError, match="hall_offset"):
        cases.generate(small, tmp_path / "cases", tmp_path / "key.json", parts=[tmp_path / "p.json"])
