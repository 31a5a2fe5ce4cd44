# Snakemake script for rule blind_generate: the cases and the key (mrhyst.blind.generate). It reads the blind
# config only: the key never depends on the diagnosis it judges (issue 11, point 5).
from pathlib import Path

from mrhyst import blind
from mrhyst.blind.settings import blind_settings
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    out_dir = Path(snakemake.output.csv[0]).parent  # noqa: F821
    settings = blind_settings(snakemake.params.config["blind"])  # noqa: F821  (once, at the boundary)
    key = blind.generate(settings, out_dir, snakemake.output.key,  # noqa: F821
                         workers=snakemake.threads)  # noqa: F821
    print(f"{len(key['cases'])} cases in {out_dir}; key {snakemake.output.key}")  # noqa: F821
