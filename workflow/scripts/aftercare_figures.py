# Snakemake script for rule aftercare_figures: the figure of every reference diagnosis of the aftercare benchmark
# (mrhyst.blind.aftercare.draw_figures; the key is not an input of this rule).
from mrhyst.blind import aftercare
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    aftercare.draw_figures(list(sm.input.diag), list(sm.output))
