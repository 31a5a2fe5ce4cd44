# Snakemake script for rule gdlaws_figure: the withheld loop's reference diagnosis drawn as every diagnosis is
# (mrhyst.report.diagfig, the figure of `mrhyst diagnose ... --figure`).
from mrhyst.data.io import read_json
from mrhyst.logs import to_log
from mrhyst.report import diagfig

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    diagfig.save(read_json(sm.input.diag), sm.output.png)
