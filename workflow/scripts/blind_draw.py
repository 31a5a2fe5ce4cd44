# Snakemake script for rule blind_draw: one part of the key's work (config blind.key_jobs), the cases of some
# classes with their reference fits (mrhyst.blind.cases.write_part). The blind config only, as blind_generate.
from mrhyst.blind import cases
from mrhyst.blind.settings import blind_settings
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = blind_settings(sm.params.config["blind"])  # once, at the boundary
    classes = cases.key_parts(cfg, sm.params.key_jobs)[int(sm.wildcards.part)]
    specs = cases.write_part(cfg, classes, sm.output[0], workers=sm.threads)
    print(f"part {sm.wildcards.part}: {len(specs)} cases of {', '.join(classes)}")
