# Snakemake script for rule external_table: one row per external loop (mrhyst.external.summary_table).
from mrhyst import external
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    df = external.write_summary(list(snakemake.input), snakemake.output[0])  # noqa: F821
    print(df.to_string())
