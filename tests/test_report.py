"""The report (issue 4). Unit tests of mrhyst.report.collect; then end to end in a repository copy with a small config:
sections in the paper's order, each with numbers; offline (nothing fetched, figures embedded); named targets build
only what they need; `snakemake --report`; and the plain "not available yet" when a stage is absent. Byte-identical
rebuilds of everything (report included) are tests/test_determinism.py."""

import html as htmllib
import json
import math
import re
import shutil

import nbformat
import numpy as np
import pytest
from mrhyst.report import collect as report
from workflow_util import ROOT, small_copy, snakemake

slow = pytest.mark.slow

HTML = "results/report/report.html"
# (heading prefix, a number that must appear in that section or None): the order
SECTIONS = [
    ("1. Provenance", None),
    ("2. N/Le", None),
    ("3. Fig. 2", None),
    ("4. Fig. 6", "0.09"),
    ("5. Table 1", "1.5034e+06"),
    ("6. Table 2", "0.0059"),
    ("7. Table 3", "0.00424"),
    ("8. Fig. 8", None),
    ("9. Fig. 9", None),
    ("10. Fig. 10", None),
    ("11. Seed spread and identifiability", None),
    ("12. Eq. (13) as printed vs the physical J-A form", None),
    ("13. The paper's internal inconsistencies", None),
    ("14. Sim-to-real diagnosis", None),
    ("Appendix A.", None),
    ("Appendix B.", "after_000"),  # issue 26: every aftercare reference diagnosis, its figure and summary
]
NUMBER = re.compile(r"(?<![\w.])[-+−]?\d+\.\d+(?:e[-+]\d+)?|(?<![\w.])\d+e[-+]\d+")
BAD = re.compile(r"\b(?:TODO|TBD|placeholder|nan|NaN|None|Traceback|Error)\b")


# --------------------------------------------------------------------------------------------
# unit tests (fast)
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nb", sorted((ROOT / "notebooks").glob("*.ipynb")), ids=lambda p: p.name)
def test_papermill_reads_every_parameter_of_the_notebook(nb):
    """papermill reads a parameters cell line by line and skips one it cannot parse (a comment with "" or an
    apostrophe in it), then warns 'Passed unknown parameter' for what the rule passes: every name assigned in the
    cell is one it reads."""
    import papermill

    cell = next(c for c in nbformat.read(nb, as_version=4).cells if "parameters" in c.metadata.get("tags", []))
    assigned = re.findall(r"^(\w+)\s*=", cell.source, flags=re.M)
    assert assigned and list(papermill.inspect_notebook(str(nb))) == assigned


def test_external_refs_finds_every_kind_of_outside_reference():
    page = ('<script src="https://cdn.example/require.js"></script><link rel="stylesheet" href="//cdn.example/a.css">'
            '<style>@import url(http://fonts.example/f.css); .x { background: url("https://e.example/i.png") }</style>'
            '<script type="module">const m = await import("https://cdn.example/mermaid.mjs");</script>')
    assert len(report.external_refs(page)) == 5
    inside = ('<img src="data:image/png;base64,iVBOR"><a href="#1.-Provenance">x</a>'
              '<a class="anchor-link" href="#t">¶</a>')
    assert report.external_refs(inside) == []


def test_export_html_refuses_a_page_that_fetches(tmp_path):
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell('<img src="https://example.org/x.png">')])
    nbformat.write(nb, str(tmp_path / "bad.ipynb"))
    with pytest.raises(ValueError, match="outside resource"):
        report.export_html(tmp_path / "bad.ipynb", tmp_path / "bad.html", ROOT / "workflow/report/offline.html.j2")
    assert not (tmp_path / "bad.html").exists()
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("## 1. A heading\n\n3.14 T")])
    nbformat.write(nb, str(tmp_path / "ok.ipynb"))
    page = report.export_html(tmp_path / "ok.ipynb", tmp_path / "ok.html", ROOT / "workflow/report/offline.html.j2")
    assert "3.14 T" in page and "<script src" not in page and report.external_refs(page) == []
    again = report.export_html(tmp_path / "ok.ipynb", tmp_path / "ok2.html", ROOT / "workflow/report/offline.html.j2")
    assert again == page


def test_git_commit_outside_a_repository_is_unknown(tmp_path):
    assert report.git_commit(tmp_path) == "unknown"
    c = report.git_commit(ROOT)
    assert c == "unknown" or re.fullmatch(r"[0-9a-f]{40}", c)


def test_negative_slopes_and_remanence():
    cur = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    B = np.array([0.0, 0.05, 0.09, 0.095, 0.026])  # B rises while the current falls: one bad interval
    ns = report.negative_slopes(cur, B)
    assert ns["n"] == 1 and ns["n_intervals"] == 4 and math.isclose(ns["min_slope_T_per_A"], -0.005)
    assert report.remanence_after_peak(cur, B) == 0.026
    assert report.negative_slopes(cur, np.array([0.0, 0.05, 0.09, 0.07, 0.026]))["n"] == 0


def test_fig6_draws_each_leg_of_a_bipolar_sweep_apart_and_titles_its_last_falling_zero():
    """A lab's bipolar sweep 0 -> +10 -> -10 -> +10 A (its loop file's branch column): three legs, each after the
    first from the turning point before it, so no line joins the two rising legs across the loop; the title's B is
    where the falling leg crosses 0 A, and on the paper's 0 -> 2 -> 0 sweep the remanence of the descent."""
    up1, down, up2 = np.linspace(0, 10, 6), np.linspace(10, -10, 11)[1:], np.linspace(-10, 10, 11)[1:]
    cur = np.concatenate([up1, down, up2])
    br = ["up"] * 6 + ["down"] * 10 + ["up"] * 10
    B = 0.01 * cur + np.where(np.array(br) == "down", 0.02, -0.02)
    assert report.monotone_legs(br) == [("up", 0, 5), ("down", 5, 15), ("up", 15, 25)]
    I0, B0 = report.falling_zero(cur, B, br)
    assert I0 == 0.0 and B0 == pytest.approx(0.02) and cur[10] == 0.0
    uni = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    assert report.monotone_legs(["up"] * 3 + ["down"] * 2) == [("up", 0, 2), ("down", 2, 4)]
    assert report.falling_zero(uni, [0.0, 0.05, 0.09, 0.06, 0.026], ["up"] * 3 + ["down"] * 2) == (0.0, 0.026)
    assert report.falling_zero(uni[:3], [0.0, 0.05, 0.09], ["up"] * 3) is None


def test_provenance_of_the_repository(config):
    raw = ROOT / "data/raw/li_gong_rig.csv"
    pv = report.provenance(config, ROOT / "config.yaml", [raw], ROOT, versions={"numpy": "x"})
    assert re.fullmatch(r"[0-9a-f]{64}", pv["config_sha256"])
    assert pv["seeds"]["pso.seeds"] == [int(s) for s in config["pso"]["seeds"]]
    assert pv["seeds"]["rig.seed"] == config["rig"]["seed"]
    m = pv["measurements"]
    assert m["synthetic"] and m["sweeps"][0]["n_samples"] == 53 and m["sweeps"][0]["n_up"] == 27
    eff = m["rig"]["effects"]
    lag = math.exp(-config["rig"]["dwell_s"] / config["rig"]["eddy_tau_s"])
    assert math.isclose(eff["eddy_lag"]["lag_per_step"], lag)
    assert set(eff["hall_offset"]["sensors"]) == {"hall1", "hall2"}
    versions = report.package_versions()
    for pkg in ("numpy", "scipy", "pandas", "matplotlib", "pyswarms", "numba", "snakemake", "papermill", "python"):
        assert versions[pkg] != "not installed", pkg


# --------------------------------------------------------------------------------------------
# end to end (slow)
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def built(small_built):
    """The shared small build (conftest.small_built: `all`, which includes `report`); read only."""
    return small_built[0]


def _text(fragment: str) -> str:
    t = re.sub(r"<style.*?</style>", " ", fragment, flags=re.S)
    t = re.sub(r"<[^>]+>", " ", t)
    return re.sub(r"\s+", " ", htmllib.unescape(t))


def _sections(page: str) -> list[tuple[str, str]]:
    """[(heading text, text up to the next h2)] for every h2 of the page."""
    parts = re.split(r"<h2[^>]*>(.*?)</h2>", page, flags=re.S)
    return [(_text(parts[i]).replace("¶", "").strip(), _text(parts[i + 1])) for i in range(1, len(parts) - 1, 2)]


@slow
def test_sections_in_order_each_with_numbers(built):
    page = (built / HTML).read_text()
    secs = _sections(page)
    heads = [h for h, _ in secs]
    assert len(heads) == len(SECTIONS), heads
    for (head, body), (want, must) in zip(secs, SECTIONS):
        assert head.startswith(want), (head, want)
        nums = NUMBER.findall(body)
        assert len(nums) >= 3, f"section {head!r} holds {len(nums)} numbers: {body[:300]}"
        assert not BAD.search(body), f"section {head!r}: {BAD.search(body).group(0)!r} in {body[:300]}"
        assert "not available yet" not in body.lower(), head  # every stage exists in this workflow
        if must:
            assert must in body, (head, must)
    data = json.loads((built / "results/report/report_data.json").read_text())
    text = dict(secs)
    prov = text[heads[0]]
    assert data["provenance"]["config_sha256"] in prov
    assert re.search(r"[0-9a-f]{64}", prov) and "synthetic" in prov.lower()
    for pkg in ("numpy", "scipy", "pandas", "matplotlib", "pyswarms", "numba", "snakemake", "papermill"):
        assert pkg in prov
    assert f"{data['nle']['n_over_le']:.6g}" in text[heads[1]]
    # the commit: "unknown" here (a copy outside git); a hash in the real repository
    assert data["provenance"]["commit"] in prov


@slow
def test_offline_and_self_contained(built):
    page = (built / HTML).read_text()
    assert report.external_refs(page) == []
    attrs = re.findall(r"""\b(?:src|href)\s*=\s*["']([^"']*)["']""", page, flags=re.I)
    assert not [a for a in attrs if re.match(r"(?:https?:)?//", a, flags=re.I)], attrs
    assert "<script src" not in page.lower() and "<link" not in page.lower()
    imgs = re.findall(r"<img[^>]*\bsrc=\"([^\"]{0,40})", page)
    # Figs. 2, 6, 8, 9, 10, one diagnosis figure per group, the blind and the external figure
    assert len(imgs) >= 9 and all(s.startswith("data:image/png;base64,") for s in imgs), imgs
    # the only URLs left are in comments of nbconvert's inlined CSS (licence notes): nothing is fetched
    outside_comments = re.sub(r"/\*.*?\*/", "", page, flags=re.S)
    assert not re.search(r"https?://", outside_comments), re.search(r".{80}https?://.{40}", outside_comments, re.S)


@slow
def test_second_run_has_nothing_to_do(built):
    p = snakemake(built, "-c2", "report")
    assert p.returncode == 0
    assert "Nothing to be done" in p.stdout + p.stderr


@slow
def test_snakemakes_own_report(built):
    p = snakemake(built, "--report", "results/snakemake_report.html")
    assert p.returncode == 0, p.stderr[-4000:]
    out = p.stdout + p.stderr
    assert "ERROR" not in out and "Undefined substitution" not in out
    for f in ("fig02.png", "fig06.png", "fig08.png", "fig09.png", "fig10.png", "table1.csv", "report.html"):
        assert f"Adding {f}" in out, f
    assert (built / "results/snakemake_report.html").stat().st_size > 0


def _jobs(wd, target) -> set:
    p = snakemake(wd, target, "-n", "-F", "--quiet", "rules")
    assert p.returncode == 0, p.stderr[-3000:]
    rows = re.findall(r"^(\w+)\s+\d+$", p.stdout + p.stderr, flags=re.M)
    return {r for r in rows if r not in ("total", "job")}


@slow
def test_named_targets_build_only_what_they_need(built):
    data_only = {"convert", "infer_nle"}
    fits = data_only | {"fit_pso", "fit_lsm", "profile", "tables"}
    assert _jobs(built, "fig2") == {"infer_nle", "simulate_fig2", "plot_fig02", "fig2"}
    assert _jobs(built, "fig6") == {"convert", "plot_fig06", "fig6"}
    assert _jobs(built, "tables") == fits
    for n in ("8", "9", "10"):
        assert _jobs(built, f"fig{n}") == fits | {f"plot_fig{int(n):02d}", f"fig{n}"}
    rep = _jobs(built, "report")
    assert {"report_forms", "report_data", "report_notebook", "report_html", "plot_fig02", "plot_fig10"} <= rep
    assert "all" not in rep


@slow
def test_absent_stages_are_said_plainly(built, tmp_path):
    """Without the diagnosis, blind and external stages the report still builds and says so."""
    wd = small_copy(tmp_path / "nodiag")
    sf = wd / "Snakefile"
    text = sf.read_text()
    for smk, repl in (("diagnose.smk", ""), ("blind.smk", "BLIND_TARGETS = []"),
                      ("external.smk", "EXTERNAL_TARGETS = []")):
        line = f'include: "workflow/rules/{smk}"'
        if line not in text:
            pytest.skip(f"Snakefile layout changed ({line} not found)")
        text = text.replace(line, repl)
    sf.write_text(text)
    shutil.copytree(built / "results", wd / "results", dirs_exist_ok=True)
    p = snakemake(wd, "-c2", "-R", "report_data", "report")
    assert p.returncode == 0, p.stderr[-4000:]
    secs = dict(_sections((wd / HTML).read_text()))
    diag = next(b for h, b in secs.items() if h.startswith("14."))
    app = next(b for h, b in secs.items() if h.startswith("Appendix"))
    # the diagnosis, the blind benchmark, its open world and its protocol variants: each says so
    assert diag.count("Not available yet") == 4 and "no rule diagnose" in diag and "blind_score" in diag
    assert "Not available yet" in app
    assert not BAD.search(diag + app)


def test_a_measured_sweep_s_report_claims_nothing_of_the_rig(built, tmp_path):
    """Sweeps whose sidecar does not say SYNTHETIC (a lab's own, in data/raw): the report calls them measurements, and
    what only the virtual rig's sweep has is not shown as theirs: the rig-labelled captions of Figs. 6 and 8, the
    'rig injected' columns of the diagnosis table, the rig variants (the workflow builds none on a lab's sweep)."""
    wd = small_copy(tmp_path / "measured")
    shutil.copytree(built / "results", wd / "results", dirs_exist_ok=True)
    data = wd / "results/report/report_data.json"
    D = json.loads(data.read_text())
    assert D["provenance"]["measurements"]["synthetic"] is True  # the rig's sweep, as shipped
    secs = dict(_sections((wd / HTML).read_text()))
    assert "rig injected" in next(b for h, b in secs.items() if h.startswith("14."))
    D["provenance"]["measurements"]["synthetic"] = False
    data.write_text(json.dumps(D))
    p = snakemake(wd, "-c2", "-R", "report_notebook", "--allowed-rules", "report_notebook", "report_html",
                  "--", HTML)
    assert p.returncode == 0, p.stderr[-4000:]
    page = (wd / HTML).read_text()
    secs = dict(_sections(page))
    assert "The sweeps are treated as measurements" in secs[next(h for h in secs if h.startswith("1."))]
    fig6 = secs[next(h for h in secs if h.startswith("4."))]
    assert "virtual rig (synthetic data)" not in fig6 and "Fig. 6: B(I) of the two Hall sensors" in fig6
    assert "measured loop" in secs[next(h for h in secs if h.startswith("8."))]
    diag = secs[next(h for h in secs if h.startswith("14."))]
    assert "rig injected" not in diag and "injected size" not in diag
    assert "Not built: the rig variants remake the virtual rig's sweep" in _text(page)
    assert not BAD.search(diag + fig6)


def test_diagnosis_regions_keep_the_order_along_the_loop(tmp_path):
    """The region table follows the loop (ascending low ... remanence point), not the JSON key order."""
    from mrhyst import diagnose

    order = list(diagnose.REGIONS)
    d = {"effect": "none", "where": {"regions": {k: {"n": 1, "share_before": 0.1} for k in sorted(order)},
                                     "region_order": order, "largest_share_before": order[0]}}
    path = tmp_path / "d.json"
    path.write_text(json.dumps(d, sort_keys=True))
    s = report.diagnosis_summary(path)
    assert [r["region"] for r in s["where"]["regions"]] == order != sorted(order)
