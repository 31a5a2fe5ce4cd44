# Snakemake script for rule diagnose: the package computes (mrhyst.diagnose), this only wires files. The config's
# diagnose section is resolved once here (over the schema's defaults) into the settings that run and are recorded.
from mrhyst import diagnose
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    d = diagnose.diagnose_file(
        snakemake.input.csv,  # noqa: F821
        sensor=snakemake.params.sensor,  # noqa: F821
        out=snakemake.output[0],  # noqa: F821
        config=diagnose.resolve_config(snakemake.params.config["diagnose"]),  # noqa: F821
    )
    print(d["verdict"])
