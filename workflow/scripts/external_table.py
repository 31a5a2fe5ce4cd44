# Snakemake script for rule external_table: one row per external loop and fit (mrhyst.materials.external.summary_table).
from mrhyst.logs import to_log
from mrhyst.materials import external

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    df = external.write_summary(list(sm.input.fits), sm.output[0], peers=sm.input.peers[0] if sm.input.peers else None)
    print(df.to_string())
