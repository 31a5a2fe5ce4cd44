# mrhyst: reproduction of Li & Gong (2019), Front. Mater. 6:111, plus sim-to-real gap diagnosis.
# Rules declare; the package (workflow/mrhyst) computes; notebooks only plot.
# `snakemake -c2` builds everything; named targets: fig2 fig6 fig8 fig9 fig10 tables external blind realcores aftercare gdlaws
# later report.

include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/fit.smk"
include: "workflow/rules/tables.smk"
include: "workflow/rules/external.smk"
include: "workflow/rules/diagnose.smk"
include: "workflow/rules/blind.smk"
include: "workflow/rules/realcores.smk"
include: "workflow/rules/reference.smk"
include: "workflow/rules/gdlaws.smk"
include: "workflow/rules/report.smk"


# Snakemake's own provenance report (`snakemake --report`): this text on its front page, captions per figure
report: "workflow/report/workflow.rst"


rule all:
    default_target: True
    input:
        ALL_TARGETS,


rule fig2:
    input:
        "results/figures/fig02.png",


rule fig6:
    input:
        "results/figures/fig06.png",


rule fig8:
    input:
        "results/figures/fig08.png",


rule fig9:
    input:
        "results/figures/fig09.png",


rule fig10:
    input:
        "results/figures/fig10.png",


rule external:
    input:
        EXTERNAL_TARGETS,


rule blind:
    input:
        BLIND_TARGETS,


rule realcores:
    input:
        REALCORES_TARGETS,


rule aftercare:
    input:
        AFTERCARE_TARGETS,


rule gdlaws:
    input:
        GDLAWS_TARGETS,


rule later:
    input:
        LATER_TARGETS + LATER_FIGS,


rule report:
    input:
        REPORT_TARGETS,
