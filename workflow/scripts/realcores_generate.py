# Snakemake script for rule realcores_generate: the real-core cases and their key (mrhyst.blind.realcores).
from pathlib import Path

from mrhyst.blind import realcores
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    key = realcores.generate(sm.params.config["realcores"], Path(sm.output.key).parent / "cases", sm.output.key)
    print(f"{len(key)} cases")
