"""Blind benchmark (mrhyst.blind): the case files leak nothing, the diagnosis cannot reach the key (DAG and
run time), generation is deterministic, and the score counts what it says."""

import builtins
import io as _pyio
import json
import os
import pathlib
import re
import runpy
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from mrhyst import blind
from mrhyst import diagnose as dg
from mrhyst.data import io
from workflow_util import ROOT, make_copy, snakemake

FAST = {"budget_seeds": 1, "n_random": 600}


@pytest.fixture(scope="module")
def generated(tmp_path_factory, small):
    d = tmp_path_factory.mktemp("blind")
    key = blind.generate(small, d / "cases", d / "key.json")
    return d, key


# ---------------------------------------------------------------- the cases leak nothing
def test_cases_are_anonymous_shuffled_and_alike(generated, small):
    d, key = generated
    ids = blind.case_ids(small)
    assert ids == [f"case_{i:03d}" for i in range(len(small["classes"]))]
    names = sorted(p.name for p in (d / "cases").iterdir())
    assert names == sorted([f"{i}.csv" for i in ids] + [f"{i}.json" for i in ids])
    classes = [key["cases"][i]["class"] for i in ids]
    assert sorted(classes) == sorted(small["classes"]) and classes != list(small["classes"])  # shuffled
    headers, side_keys = set(), set()
    for i in ids:
        text = (d / "cases" / f"{i}.csv").read_text() + (d / "cases" / f"{i}.json").read_text()
        for word in ("offset", "remanent", "eddy", "lag", "drift", "saturation", "air_gap", "none", "effect", "truth",
                     "preisach", "phase", "gain", "leak", "mechanism"):
            assert word not in text, (i, word)
        headers.add((d / "cases" / f"{i}.csv").read_text().splitlines()[0])
        side = json.loads((d / "cases" / f"{i}.json").read_text())
        side_keys.add((tuple(sorted(side)), tuple(sorted(side["sensors"]["hall1"]))))
    # every case has the same columns and the same sidecar keys (no output limits that would betray a clip)
    assert headers == {"step,time_s,current_A,hall1_V"}
    assert side_keys == {(("coil_turns_per_m", "dwell_s", "sensors", "supply_V"),
                          ("quiescent_V", "sensitivity_V_per_T"))}


def test_generation_is_deterministic(generated, small, tmp_path):
    """Same config, same bytes; also with the reference fits in two processes (rule blind_generate's threads),
    which draw ahead and must still give exactly the cases drawn one by one."""
    d, _ = generated
    blind.generate(small, tmp_path / "cases", tmp_path / "key.json", workers=2)
    for p in sorted((d / "cases").iterdir()):
        assert (tmp_path / "cases" / p.name).read_bytes() == p.read_bytes(), p.name
    assert (tmp_path / "key.json").read_bytes() == (d / "key.json").read_bytes()


def test_key_records_detectability_and_equivalents(generated):
    _, key = generated
    kinds = {c["class"]: c["kind"] for c in key["cases"].values()}
    assert kinds["hall_offset"] == "closed" and kinds["hall_offset+eddy_lag"] == "compound"
    assert kinds["preisach"] == kinds["hall_gain_drift"] == "openworld"
    for c in key["cases"].values():
        if c["class"] == "none":
            assert not c["detectable"] and c["equivalent_to"] == [] and c["size_param"] is None
            assert c["rms_left_T"] < 1e-9  # the reference reproduces a plain J-A loop from its truth
            continue
        assert c["detectable"] == (c["rms_left_T"] >= 1.5 * c["sigma_eff_T"])
        assert c["class"] not in c["equivalent_to"]
        own = set(c["members"]) if c["kind"] == "closed" else set()
        assert set(c["alternatives_rms_T"]) == set(blind.EFFECTS) - own
        if c["kind"] == "compound":
            assert set(c["needed"]) == set(c["members"]) == {"hall_offset", "eddy_lag"}
            assert set(c["effect_params"]) == {"hall_offset", "eddy_lag"}
        if c["kind"] == "openworld":
            assert c["mechanism_params"] and c["members"] == []
            assert c["vocab_closes"] == [e for e, a in c["alternatives_rms_T"].items() if a < 1.5 * c["sigma_eff_T"]]
    assert key["cases"][next(i for i, c in key["cases"].items() if c["class"] == "preisach")]["truth"] is None


def test_detectable_only_redraws_absorbed_effects(generated, small):
    """With detectable_only (the workflow's setting) every effect case is detectable (compound: each member
    needed); without it the same seed gives absorbed ones too (the ranges reach below the detection limit)."""
    _, key = generated
    assert small["detectable_only"] is True
    assert all(c["detectable"] for c in key["cases"].values() if c["class"] != "none")
    assert all(all(c["needed"].values()) for c in key["cases"].values() if c["kind"] == "compound")
    loose = blind.draw_cases(dict(small, n_per_class=6, classes=["air_gap"], detectable_only=False))
    left = [s["reference"]["rms_left_T"] / blind.effective_sigma(s) for s in loose]
    assert min(left) < small["detectable_factor"]  # an air gap at the paper's drive is mostly absorbed


def test_key_of_a_kept_draw_is_the_same_when_refits_are_skipped_or_stopped(small):
    """detectable_only skips the refits of a draw once it cannot be a case and stops a compound's refits once
    one effect gets below the detection level; a draw that IS kept must get exactly the key a full evaluation
    gives (every refit to the end), and a compound is kept only when no single effect closes its loop."""
    from mrhyst.blind import cases as C

    cfg = dict(small, classes=["hall_offset", "eddy_lag", "hall_offset+eddy_lag", "eddy_lag+sensor_saturation"])
    rng = np.random.default_rng(7)
    cur = C.current_path(cfg)
    kept = 0
    for cls in cfg["classes"] * 4:
        spec = None
        while spec is None:
            spec = C._draw_one(cls, C.class_kind(cls), rng, cfg, cur)
        lazy = C.detectability(spec, cfg)
        full = C.detectability(spec, dict(cfg, detectable_only=False))
        assert C._wanted(spec, lazy, cfg) == C._wanted(spec, full, dict(cfg, detectable_only=True))
        if C._wanted(spec, lazy, cfg):
            kept += 1
            assert {k: v for k, v in lazy.items()} == full
            if spec["kind"] == "compound":
                assert full["vocab_closes"] == []
    assert kept >= 4, kept


def test_reference_recovers_a_known_set_from_its_own_noise_free_loop(small):
    """The key's reference (scipy least_squares) started 30 % off the truth finds it again on a plain J-A
    loop; and it runs without the diagnosis (the key must not depend on what it judges)."""
    from mrhyst import rig
    from mrhyst.blind import reference as ref
    from mrhyst.model import ja

    truth = {"Ms": 1.3e6, "a": 3.0e4, "alpha": 2.0e-3, "c": 0.35, "k": 1.5e4}
    I = ja.paper_current_path()
    t = rig.sample_times(I.size, 0.1)
    B, _ = rig.observe(ja.as_param_array(truth), I, t, 3.0e4, [], substeps=8)
    loop = ref.Loop(B, I, t, 3.0e4, 8)
    start = ja.as_param_array(truth) * np.array([1.3, 0.75, 1.3, 0.8, 1.3])
    rms, P = ref.plain_fit(loop, [start], small["reference"]["box"], 2000)
    assert rms < 1e-7 * np.max(B)
    assert np.allclose(P, ja.as_param_array(truth), rtol=1e-3)
    # an offset on that loop: plain J-A cannot close it, J-A + hall_offset does
    loop2 = ref.Loop(B + 2e-3, I, t, 3.0e4, 8)
    left, P2 = ref.plain_fit(loop2, [ja.as_param_array(truth)], small["reference"]["box"], 300)
    assert left > 1e-4
    assert ref.effect_fit(loop2, "hall_offset", P2, small["reference"]["box"], 300) < 1e-6


def test_generation_needs_no_diagnosis(small, tmp_path):
    """blind_generate's script, given the blind config alone (as the rule passes it), makes cases and key with
    mrhyst.diagnose unimportable: the key is independent of the system under test (issue 11 point 5)."""
    import subprocess

    cfg = dict(small, classes=["none", "leakage"])
    code = ("import sys, json, runpy; sys.modules['mrhyst.diagnose'] = None\n"
            "from types import SimpleNamespace as S\n"
            f"cfg = json.loads({json.dumps(json.dumps(cfg))})\n"
            f"d = {str(tmp_path)!r}\n"
            "fake = S(input=S(), output=S(csv=[d + '/cases/case_000.csv'], key=d + '/key.json'), log=[d + '/gen.log'],"
            " params=S(config={'blind': cfg}), threads=2)\n"
            "runpy.run_path(sys.argv[1], init_globals={'snakemake': fake})\n")
    p = subprocess.run([sys.executable, "-c", code, str(ROOT / "workflow/scripts/blind_generate.py")],
                       capture_output=True, text=True, env=dict(os.environ))
    assert p.returncode == 0, p.stderr[-2000:]
    assert sorted(json.loads((tmp_path / "key.json").read_text())["cases"]) == ["case_000", "case_001"]
    rule = (ROOT / "workflow/rules/blind.smk").read_text().split("\nrule blind_diagnose:")[0]
    params = rule.split("params:")[1].split("log:")[0]
    assert '{"blind": _bcfg}' in params and "diagnose" not in params  # the blind config (of its benchmark) only


def test_bipolar2_protocol_path_and_cases(small, tmp_path):
    """protocol bipolar2: a virgin rise, then two full +-I cycles (issue 13); the cases are generated on it."""
    cfg = dict(small, protocol="bipolar2", classes=["none", "hall_offset", "preisach"])
    I = blind.current_path(cfg)
    n = int(cfg["n_up"])
    assert I.size == n + 8 * (n - 1) and I[0] == 0.0 and I[-1] == cfg["i_max_A"] and I.min() == -cfg["i_max_A"]
    turns = np.flatnonzero(np.diff(np.sign(np.diff(I))) != 0)
    assert turns.size == 4  # +I, -I, +I, -I reversals
    key = blind.generate(cfg, tmp_path / "cases", tmp_path / "key.json")
    assert len(key["cases"]) == 3 and key["settings"]["protocol"] == "bipolar2"
    for cid in key["cases"]:
        raw = io.read_raw(tmp_path / "cases" / f"{cid}.csv")  # a valid raw sweep, as convert reads it
        assert np.allclose(raw.current_A, I)


def test_unipolar2_protocol_is_the_paper_sweep_twice(small):
    """protocol unipolar2 (issue 23): 0 -> I -> 0 and again, the 0 A reading between the passes shared; the
    diagnosis classes it as a repeated unipolar sweep (the protocol the confound tables name for a drift)."""
    from mrhyst.diagnose.confounds import protocol_class

    cfg = dict(small, protocol="unipolar2")
    n, i_max = int(cfg["n_up"]), float(cfg["i_max_A"])
    I = blind.current_path(cfg)
    once = np.r_[np.linspace(0.0, i_max, n), np.linspace(i_max, 0.0, n)[1:]]
    assert np.allclose(I, np.r_[once, once[1:]]) and I.size == 4 * (n - 1) + 1
    assert protocol_class(I) == "unipolar_repeated" and protocol_class(once) == "unipolar_single"


# ---------------------------------------------------------------- the diagnosis cannot reach the key
_AUDIT = {"guard": None}


def _audit(event, args):
    """Python's audit hook sees every file open, also from C code and from modules that bound open early."""
    g = _AUDIT["guard"]
    if g is not None and event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        g.check(args[0])


sys.addaudithook(_audit)


class KeyGuard:
    """Every way the code could open a file, refused (loudly, and recorded) for paths naming the key:
    builtins.open, io.open, os.open, Path.open/read_text/read_bytes patched, plus an audit hook on 'open'."""

    def __init__(self, monkeypatch, needle=blind.KEY_FILENAME):
        self.needle = needle
        self.hits = []
        self.opened = []
        monkeypatch.setitem(_AUDIT, "guard", self)

        self.check = check = self._check

        def wrap(fn):
            def inner(file, *a, **k):
                check(file)
                return fn(file, *a, **k)
            return inner

        def wrap_method(fn):
            def inner(self_, *a, **k):
                check(self_)
                return fn(self_, *a, **k)
            return inner

        monkeypatch.setattr(builtins, "open", wrap(builtins.open))
        monkeypatch.setattr(_pyio, "open", wrap(_pyio.open))
        monkeypatch.setattr(os, "open", wrap(os.open))
        for name in ("open", "read_text", "read_bytes"):
            monkeypatch.setattr(pathlib.Path, name, wrap_method(getattr(pathlib.Path, name)))

    def _check(self, path):
        s = os.fsdecode(path) if isinstance(path, (str, bytes, os.PathLike)) else str(path)
        self.opened.append(s)
        if self.needle in s:
            self.hits.append(s)
            raise PermissionError(f"KEY ACCESS: {s}")


def test_guard_catches_every_read_of_the_key(generated, monkeypatch):
    d, _ = generated
    key = d / "key.json"
    g = KeyGuard(monkeypatch)
    for attempt in (lambda: open(key), lambda: key.read_text(), lambda: key.read_bytes(),
                    lambda: io.read_json(key), lambda: np.loadtxt(key), lambda: os.open(key, os.O_RDONLY)):
        with pytest.raises(PermissionError, match="KEY ACCESS"):
            attempt()
    assert len(g.hits) >= 6


def test_blind_diagnose_job_never_reads_the_key(generated, config, monkeypatch):
    """Run the rule's script for a case, key on disk beside the cases: any attempt to open it fails the test."""
    d, key = generated
    case = "case_000"
    out = d / "diag" / f"{case}.json"
    g = KeyGuard(monkeypatch)
    fake = SimpleNamespace(
        input=SimpleNamespace(csv=str(d / "cases" / f"{case}.csv"), json=str(d / "cases" / f"{case}.json")),
        output=[str(out)], log=[str(d / "logs" / f"{case}.log")],
        params=SimpleNamespace(config={"diagnose": dict(config["diagnose"], **FAST)}))  # config_of("diagnose")
    runpy.run_path(str(ROOT / "workflow/scripts/blind_diagnose.py"), init_globals={"snakemake": fake})
    assert g.hits == []
    assert any(s.endswith(f"{case}.csv") for s in g.opened)  # the guard did see the job's reads
    dg_out = json.loads(out.read_text())
    assert dg_out["effect"] in dg.CANDIDATES + ("none", "unexplained", "model_form")
    assert "key" not in out.read_text()


def test_blind_diagnose_job_records_a_refused_sweep_as_failed(tmp_path, config):
    """A sweep the diagnosis refuses (here: a case whose current only rises, cut after its turning point) is a
    scored failure, not a stopped workflow."""
    cfg = dict(config["blind"], n_per_class=1, counts={}, classes=["none"])
    blind.generate(cfg, tmp_path / "cases", tmp_path / "key.json")
    csv = tmp_path / "cases" / "case_000.csv"
    rows = csv.read_text().splitlines()
    csv.write_text("\n".join(rows[: 1 + int(cfg["n_up"])]) + "\n")  # header + the ascent only
    out = tmp_path / "diag" / "case_000.json"
    fake = SimpleNamespace(
        input=SimpleNamespace(csv=str(csv), json=""),
        output=[str(out)], log=[str(tmp_path / "case_000.log")],
        params=SimpleNamespace(config={"diagnose": dict(config["diagnose"], **FAST)}))
    runpy.run_path(str(ROOT / "workflow/scripts/blind_diagnose.py"), init_globals={"snakemake": fake})
    d = json.loads(out.read_text())
    assert d["effect"] == blind.FAILED and "reversal" in d["error"] and d["rms_after_T"] is None
    s = blind.score([out], tmp_path / "key.json", cfg)
    assert s["failed"] == 1 and s["overall"]["top1_fair"] == 0.0


@pytest.mark.slow
def test_dag_gives_blind_diagnose_only_its_cases(tmp_path, small):
    """Dry run of the workflow: a blind_diagnose job (a block of 10 cases) has exactly its own cases' CSVs and
    sidecars among its inputs, a benchmark's blind_diagnose_rest job (its leftover cases) theirs; no job but
    blind_score has the key (or another benchmark's file)."""
    # 12 cases: one block of 10 and two leftovers
    classes = list(small["classes"]) + ["hall_offset+thermal_drift", "two_phase"]
    wd = make_copy(tmp_path / "wf", {"blind": {"n_per_class": 1, "classes": classes, "cases_per_job": 10,
                                               "counts": {c: 1 for c in classes},
                                               "variants": {"bipolar2": {"classes": ["none", "hall_offset"],
                                                                         "n_per_class": 1},
                                                            "unipolar2": {"classes": ["none"], "n_per_class": 1}}}})
    p = snakemake(wd, "-n", "-F", "-c1", "blind")
    assert p.returncode == 0, p.stderr[-3000:]
    jobs, rule = {}, None  # the dry run lists every job: "rule NAME:" then indented "input: a, b"
    for line in p.stdout.splitlines():
        m = re.match(r"^(?:local)?rule (\w+):", line)
        if m:
            rule = m.group(1)
            jobs.setdefault(rule, []).append([])
        elif rule and line.strip().startswith("input:"):
            jobs[rule][-1] = [x.strip() for x in line.split("input:", 1)[1].split(",") if x.strip()]
    import yaml

    n = len(blind.case_ids(yaml.safe_load((wd / "config.yaml").read_text())["blind"]))
    assert n == len(classes) == 12
    block = [f"results/blind/cases/case_{i:03d}.{ext}" for ext in ("csv", "json") for i in range(10)]
    assert [sorted(x) for x in jobs["blind_diagnose"]] == [sorted(block)]
    for rule, b, ids in (("blind_diagnose_rest", "results/blind/", (10, 11)),
                         ("blind_diagnose_rest_bipolar2", "results/blind_variants/bipolar2/", (0, 1)),
                         ("blind_diagnose_rest_unipolar2", "results/blind_variants/unipolar2/", (0,))):
        assert [sorted(x) for x in jobs[rule]] == [sorted(f"{b}cases/case_{i:03d}.{ext}" for ext in ("csv", "json")
                                                          for i in ids)]
    keys = sorted(x for js in jobs["blind_score"] for x in js if "key.json" in x)
    assert keys == ["results/blind/key.json", "results/blind_variants/bipolar2/key.json",
                    "results/blind_variants/unipolar2/key.json"]
    readers = {r for r, js in jobs.items() for inputs in js if any("key.json" in x for x in inputs)}
    assert readers == {"blind_score"}, readers


def test_blocks_cover_every_case_once():
    """The jobs of a benchmark (mrhyst.blind.split_blocks): full blocks of 1, 10 or 100 case ids and the rest
    (fewer than a block); every id in exactly one of them, whatever N."""
    for n in (1, 9, 10, 14, 56, 204, 1000, 10003):
        ids = blind.case_ids({"n_per_class": n, "classes": ["none"]})
        for k in (1, 10, 100):
            stems, rest = blind.split_blocks(ids, k)
            d = len(str(k)) - 1
            covered = [f"{s}{j:0{d}d}" if d else s for s in stems for j in range(k)] + rest
            assert sorted(covered) == ids and len(covered) == len(set(covered)), (n, k)
            assert len(rest) < k, (n, k)
    assert blind.split_blocks(blind.case_ids({"n_per_class": 204, "classes": ["none"]}), 10)[1] == [
        "case_200", "case_201", "case_202", "case_203"]
    with pytest.raises(ValueError, match="1, 10 or 100"):
        blind.block_digits(20)


def test_a_block_of_cases_gives_each_case_its_own_bytes(generated, config, tmp_path):
    """Several cases diagnosed in one process (mrhyst.blind.diagnose_cases, rule blind_diagnose) give each case
    the bytes it gets alone in a fresh call: nothing of one case leaks into the next."""
    d, _ = generated
    ids = ["case_000", "case_001", "case_002"]
    cfg = dict(config["diagnose"], **FAST)
    csvs = [str(d / "cases" / f"{i}.csv") for i in ids]
    blind.diagnose_cases(csvs, [tmp_path / "block" / f"{i}.json" for i in ids], cfg, log=lambda s: None)
    blind.diagnose_cases(csvs[2:], [tmp_path / "alone" / "case_002.json"], cfg, log=lambda s: None)
    blind.diagnose_cases(csvs[:1], [tmp_path / "alone" / "case_000.json"], cfg, log=lambda s: None)
    for i in ("case_000", "case_002"):
        assert (tmp_path / "block" / f"{i}.json").read_bytes() == (tmp_path / "alone" / f"{i}.json").read_bytes()


# ---------------------------------------------------------------- the same, from the command line
def test_cli_blind_generate_diagnose_score(generated, small, tmp_path, capsys):
    """`mrhyst blind generate` writes the workflow's cases byte for byte (same config, same seed); each case
    is diagnosed with `mrhyst diagnose --config`, and `mrhyst blind score` takes a folder of diagnoses."""
    import yaml
    from mrhyst import cli

    d, key = generated
    full = yaml.safe_load((ROOT / "config.yaml").read_text())
    full["blind"]["classes"] = list(small["classes"])
    full["blind"]["reference"] = key["settings"]["reference"]  # the fixture's (smaller) reference budget
    cfg = str(tmp_path / "config.yaml")
    pathlib.Path(cfg).write_text(yaml.safe_dump(full))
    assert cli.main(["blind", "generate", "--config", cfg, "--cases", str(tmp_path / "cases"),
                     "--key", str(tmp_path / "key" / "key.json"), "--n-per-class", "1"]) == 0
    assert f"{len(small['classes'])} cases in" in capsys.readouterr().out
    for p in sorted((d / "cases").iterdir()):
        assert (tmp_path / "cases" / p.name).read_bytes() == p.read_bytes(), p.name
    assert (tmp_path / "key" / "key.json").read_bytes() == (d / "key.json").read_bytes()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folder left
    two = sorted(key["cases"])[:2]
    for cid in two:
        assert cli.main(["diagnose", str(tmp_path / "cases" / f"{cid}.csv"), "--sensor", blind.SENSOR,
                         "--config", cfg, "--out", str(tmp_path / "diag" / f"{cid}.json")]) == 0
    assert cli.main(["blind", "score", str(tmp_path / "diag"), "--key", str(tmp_path / "key" / "key.json"),
                     "--config", cfg, "--out", str(tmp_path / "score.json")]) == 0
    s = json.loads((tmp_path / "score.json").read_text())
    assert s["n_cases"] == 2 and "false attribution" in capsys.readouterr().out
    direct = blind.score(sorted((tmp_path / "diag").glob("*.json")), tmp_path / "key" / "key.json",
                         dict(json.loads((tmp_path / "key" / "key.json").read_text())["settings"]))
    assert s["overall"] == direct["overall"]


@pytest.mark.parametrize("case", ["cases_not_empty", "key_in_cases", "bad_config", "unknown_class", "no_diag",
                                  "twice", "not_a_diagnosis", "not_a_key"])
def test_cli_blind_bad_input_is_one_line_and_writes_nothing(case, tmp_path, capsys, config):
    import yaml
    from mrhyst import cli

    cfg = tmp_path / "in" / "config.yaml"
    cfg.parent.mkdir()
    bad = dict(config)
    if case == "bad_config":
        bad = dict(config, blind=dict(config["blind"], n_per_clas=3))
    if case == "unknown_class":
        bad = dict(config, blind=dict(config["blind"], classes=["none", "gremlins"]))
    cfg.write_text(yaml.safe_dump(bad))
    out = tmp_path / "out"
    out.mkdir()
    gen = ["blind", "generate", "--config", str(cfg), "--n-per-class", "1"]
    expect = {"cases_not_empty": "must be a new or empty folder", "key_in_cases": "outside the case folder",
              "bad_config": "n_per_clas", "unknown_class": "gremlins", "no_diag": "no diagnosis files",
              "twice": "more than once", "not_a_diagnosis": "not a diagnosis (missing rms_before_T",
              "not_a_key": "not a blind key"}[case]
    if case == "cases_not_empty":
        (out / "cases").mkdir()
        (out / "cases" / "mine.csv").write_text("x\n")
        argv = gen + ["--cases", str(out / "cases"), "--key", str(out / "key.json")]
    elif case == "key_in_cases":
        argv = gen + ["--cases", str(out / "cases"), "--key", str(out / "cases" / "key.json")]
    elif case in ("bad_config", "unknown_class"):
        argv = gen + ["--cases", str(out / "cases"), "--key", str(out / "key.json")]
    else:
        diag = tmp_path / "in" / "diag"
        diag.mkdir()
        io.write_json({} if case == "not_a_key" else {"cases": {"case_000": {}}}, tmp_path / "in" / "key.json")
        if case in ("not_a_diagnosis", "not_a_key"):
            io.write_json({"effect": "none"}, diag / "case_000.json")
            argv = ["blind", "score", str(diag)]
        elif case == "twice":
            io.write_json({"effect": "none"}, diag / "case_000.json")
            argv = ["blind", "score", str(diag / "case_000.json"), str(diag)]
        else:
            argv = ["blind", "score", str(diag)]
        argv += ["--key", str(tmp_path / "in" / "key.json"), "--config", str(cfg), "--out", str(out / "s.json")]
    rc = cli.main(argv)
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err and expect in err, err
    left = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    assert left == (["cases", "cases/mine.csv"] if case == "cases_not_empty" else []), left


def test_reference_effect_fits_nest_plain_ja(small):
    """J-A + an effect contains plain J-A (Nd = 0, drift 0, B_sat above the top): its reference RMS is never
    above plain J-A's, even on a loop J-A cannot fit (a Preisach core)."""
    from mrhyst import rig
    from mrhyst.blind import openworld
    from mrhyst.blind import reference as ref
    from mrhyst.model import ja

    I = ja.paper_current_path()
    t = rig.sample_times(I.size, 0.1)
    mp = {"Ms": 1.2e6, "hc": 8.0e3, "hc_logsd": 0.5, "hu_sd": 4.0e3, "rev_frac": 0.1, "h_rev": 5.0e4}
    B, _, ok = openworld.field("preisach", mp, None, I, t, 3.0e4)
    loop = ref.Loop(B, I, t, 3.0e4, 8)
    starts = ref.screened_starts(loop, small["truth_box"], 32, 2, seed=1)
    box = small["reference"]["box"]
    plain, P = ref.plain_fit(loop, starts, box, 200)
    assert plain > 1e-3  # a Preisach core is far from J-A
    for e in ("air_gap", "thermal_drift", "sensor_saturation"):
        assert ref.effect_fit(loop, e, P, box, 200) <= plain * (1 + 1e-12), e
