# mrhyst: reproduction of Li & Gong (2019), Front. Mater. 6:111, plus sim-to-real gap diagnosis.
# Rules declare; the package (workflow/mrhyst) computes; notebooks only plot.
# `snakemake -c2` builds everything; named targets: fig2 fig6 (more as the stages land).

include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/simulate.smk"


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
