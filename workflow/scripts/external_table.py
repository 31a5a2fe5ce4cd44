# Snakemake script for rule external_table: one row per external loop and fit (mrhyst.materials.exttable.summary_table),
# and one row per file and J-A variant of the `--model auto` comparison (exttable.model_rows, issue 26).
from mrhyst.data.io import write_csv
from mrhyst.logs import to_log
from mrhyst.materials import exttable

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    peers = sm.input.peers[0] if sm.input.peers else None
    df = exttable.write_summary(list(sm.input.fits), sm.output.table, peers=peers)
    print(df.to_string())
    models = exttable.model_rows(list(sm.input.fits))
    write_csv(models, sm.output.models)
    print(models.to_string())
