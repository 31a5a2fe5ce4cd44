# Snakemake script for rule external_diagnose: every loop of one third-party B(H) file diagnosed
# (mrhyst.diagnose.diagnose_bh_source; issue 13): the verdict table of the report's appendix.
from mrhyst.data.io import write_json
from mrhyst.diagnose import diagnose_bh_source, resolve_config
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    rows = diagnose_bh_source(sm.input.csv, resolve_config(sm.params.config["diagnose"]))
    write_json({"source": sm.wildcards.source, "path": sm.input.csv, "loops": rows}, sm.output[0])
