# Snakemake script for rule blind_generate: the cases and the key (mrhyst.blind.generate), from the blind_draw
# parts where config blind.key_jobs > 1. It reads the blind config only: the key never depends on the diagnosis
# it judges (issue 11, point 5).
from pathlib import Path

from mrhyst import blind
from mrhyst.blind.settings import blind_settings
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    out_dir = Path(sm.output.csv[0]).parent
    settings = blind_settings(sm.params.config["blind"])  # once, at the boundary
    parts = list(getattr(sm.input, "parts", None) or []) or None
    key = blind.generate(settings, out_dir, sm.output.key, workers=sm.threads, parts=parts)
    print(f"{len(key['cases'])} cases in {out_dir}; key {sm.output.key}" + (f" ({len(parts)} parts)" if parts else ""))
