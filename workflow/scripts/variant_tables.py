# Snakemake script for rule variant_tables: Tables 1-3 of a rig variant's fits (mrhyst.paper.tables.make_tables).
from pathlib import Path

from mrhyst.logs import to_log
from mrhyst.paper import tables as metrics

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    its = tuple(int(i) for i in sm.params.config["metrics"]["iterations"])
    out = metrics.make_tables(sm.input.fits, sm.params.config["paper"], Path(sm.output.table1).parent, iterations=its)
    print({k: str(v) for k, v in out.items()})
