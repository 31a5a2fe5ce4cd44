# The report (issue 4): every number of the paper beside ours in one offline HTML file.
#   report_forms     what the physical J-A form changes (mrhyst.report.collect.form_comparison)
#   report_data      provenance + every number the report shows, in one JSON (mrhyst.report.collect.collect)
#   report_notebook  papermill (-k python3) of notebooks/report.ipynb: reads that JSON and the figures only
#   report_html      nbconvert with an offline template (mrhyst.report.collect.export_html; fails on any http(s) reference)
# Included after every other stage: the diagnosis, blind and external sections depend on those stages' outputs
# only when their rules exist (rules.has), and otherwise say plainly that they are not available yet.
import json as _json

from mrhyst.report import collect as _report

_REPORT_HAS_DIAGNOSIS = rules.has("diagnose") and rules.has("diagnosis_figure")
_REPORT_HAS_BLIND = rules.has("blind_score") and rules.has("blind_figure")
_REPORT_HAS_EXTERNAL = rules.has("external_table") and rules.has("external_figure")
_REPORT_HAS_LATER = rules.has("later_diagnose")
_REPORT_RAW = sorted({raw_csv(g) for g in GROUPS})
_REPORT_LOOPS = expand("results/loops/{group}.csv", group=GROUPS)
# params, so that a new commit or another package version re-runs the collection (Snakemake's params trigger)
_REPORT_COMMIT = _report.git_state(workflow.basedir)
_REPORT_VERSIONS = _report.package_versions()
# the config file whose sha256 the report prints: the last one given (config.yaml unless --configfile)
_REPORT_CONFIG = str(workflow.configfiles[-1]) if workflow.configfiles else "config.yaml"


rule report_forms:
    """Table 1 sets in both J-A forms; the selected fits evaluated and refitted in the other form."""
    input:
        nle="results/sim/n_over_le.json",
        loops=_REPORT_LOOPS,
        selected="results/tables/selected_fits.json",
    output:
        "results/report/forms.json",
    params:
        config=config_of(*STUDY_CONFIG),
        groups=GROUPS,
    priority: GATE_PRIORITY
    log:
        "results/logs/report_forms.log",
    script:
        "../scripts/report_forms.py"


rule report_data:
    """Provenance (commit, config sha256, seeds, versions, the rig) and every number of the report."""
    input:
        config=_REPORT_CONFIG,
        raw=_REPORT_RAW,
        raw_json=[p[: -len(".csv")] + ".json" for p in _REPORT_RAW],
        nle="results/sim/n_over_le.json",
        fig2="results/sim/fig2.csv",
        loops=_REPORT_LOOPS,
        table1="results/tables/table1.csv",
        table2="results/tables/table2.csv",
        table3="results/tables/table3.csv",
        seed_spread="results/tables/seed_spread.csv",
        identifiability="results/tables/identifiability.csv",
        paper_check="results/tables/paper_check.json",
        selected="results/tables/selected_fits.json",
        forms="results/report/forms.json",
        diagnosis=expand("results/diagnosis/{group}.json", group=GROUPS) if _REPORT_HAS_DIAGNOSIS else [],
        blind=["results/blind/score.json"] if _REPORT_HAS_BLIND else [],
        blind_variants=[f"results/{b}score.json" for b in BLIND_BENCHES if b != "blind/"] if _REPORT_HAS_BLIND else [],
        external=["results/tables/external.csv"] if _REPORT_HAS_EXTERNAL else [],
        external_models=["results/tables/external_models.csv"] if _REPORT_HAS_EXTERNAL else [],
        external_diag=expand("results/external/diag/{source}.json", source=EXTERNAL_SOURCES)
        if _REPORT_HAS_EXTERNAL and rules.has("external_diagnose") else [],
        # rig variants (config rig.variants): their Tables 1-3 and loops (results/variants/NAME/)
        realcores=["results/realcores/score.json"] if rules.has("realcores_score") else [],
        aftercare=["results/aftercare/score.json"] if rules.has("aftercare_score") else [],
        aftercare_diag=expand("results/aftercare/diag/{case}.json", case=AFTERCARE_IDS)
        if rules.has("aftercare_score") else [],  # issue 26: each case's plain summary in the appendix
        # issue 24 item 4: the gadolinium laws with one temperature withheld (gdlaws.in_all false: left out)
        gdlaws=["results/tables/gdlaws.csv", "results/gdlaws/withheld_diag.json"]
        if rules.has("gdlaws_table") and GDLAWS["in_all"] else [],
        # issue 26: a later sweep against the calibration from the first (target later, rules in reference.smk)
        later_cal=["results/later/calibration.json"] if _REPORT_HAS_LATER else [],
        later_settings=["results/later/sweeps/settings.json"] if _REPORT_HAS_LATER else [],
        later_ref=expand("results/later/diag/{c}_reference.json", c=LATER_CHANGES) if _REPORT_HAS_LATER else [],
        later_plain=expand("results/later/diag/{c}_plain.json", c=LATER_CHANGES) if _REPORT_HAS_LATER else [],
        later_figs=expand("results/figures/later/{c}_reference.png", c=LATER_CHANGES) if _REPORT_HAS_LATER else [],
        variant_tables=expand("results/variants/{variant}/tables/table2.csv", variant=RIG_VARIANTS),
        variant_loops=expand("results/variants/{variant}/loops/{group}.csv", variant=RIG_VARIANTS, group=GROUPS),
    output:
        "results/report/report_data.json",
    params:
        config=config,  # the whole config (the report shows it)
        groups=GROUPS,
        commit=_REPORT_COMMIT,
        versions=_REPORT_VERSIONS,
        has_diagnosis=_REPORT_HAS_DIAGNOSIS,
        has_blind=_REPORT_HAS_BLIND,
        has_external=_REPORT_HAS_EXTERNAL,
        variants=RIG_VARIANTS,
        later_changes=LATER_CHANGES if _REPORT_HAS_LATER else [],
    log:
        "results/logs/report_data.log",
    script:
        "../scripts/report_data.py"


rule report_notebook:
    input:
        nb="notebooks/report.ipynb",
        data="results/report/report_data.json",
        fig02="results/figures/fig02.png",
        fig06="results/figures/fig06.png",
        fig08="results/figures/fig08.png",
        fig09="results/figures/fig09.png",
        fig10="results/figures/fig10.png",
        diag_figs=expand("results/figures/diagnosis_{group}.png", group=GROUPS) if _REPORT_HAS_DIAGNOSIS else [],
        blind_fig=["results/figures/blind.png"] if _REPORT_HAS_BLIND else [],
        external_fig=["results/figures/external.png"] if _REPORT_HAS_EXTERNAL else [],
        external_diag_figs=expand("results/figures/external_diag/{source}", source=EXTERNAL_SOURCES)
        if _REPORT_HAS_EXTERNAL and rules.has("external_diagnose") else [],
        later_figs=expand("results/figures/later/{c}_reference.png", c=LATER_CHANGES) if _REPORT_HAS_LATER else [],
        aftercare_figs=AFTERCARE_FIGS if rules.has("aftercare_figures") else [],
        gdlaws_fig=["results/figures/gdlaws_withheld.png"] if rules.has("gdlaws_figure") and GDLAWS["in_all"] else [],
    output:
        nb="results/report/report.ipynb",
    params:
        nbparams=lambda w, input: nbparams(
            data=input.data, fig02=input.fig02, fig06=input.fig06, fig08=input.fig08, fig09=input.fig09,
            fig10=input.fig10, diag_figs=",".join(input.diag_figs), blind_fig=",".join(input.blind_fig),
            external_fig=",".join(input.external_fig), external_diag_figs=",".join(input.external_diag_figs),
            later_figs=",".join(input.later_figs), aftercare_figs=",".join(input.aftercare_figs),
            gdlaws_fig=",".join(input.gdlaws_fig),
        ),
    log:
        "results/logs/report_notebook.log",
    shell:
        PAPERMILL


rule report_html:
    """nbconvert without any script or style from the network; figures are embedded as data: URIs."""
    input:
        nb="results/report/report.ipynb",
        template="workflow/report/offline.html.j2",
    output:
        report(
            "results/report/report.html",
            caption="../report/report_html.rst",
            category="Report",
        ),
    log:
        "results/logs/report_html.log",
    script:
        "../scripts/report_html.py"


REPORT_TARGETS = ["results/report/report.html"]
ALL_TARGETS += REPORT_TARGETS
