# Snakemake script for rule blind_diagnose: one anonymous case, diagnosed like any lab's file. It receives
# the case's CSV (and its sidecar beside it) and nothing else: no key, no case list.
from mrhyst import blind, diagnose
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    d = diagnose.diagnose_file(
        snakemake.input.csv,  # noqa: F821
        sensor=blind.SENSOR,
        out=snakemake.output[0],  # noqa: F821
        config=snakemake.params.config["diagnose"],  # noqa: F821
    )
    print(d["verdict"])
