# Snakemake script for rule warmup: compile (or load) one group of numba kernels into the cache (mrhyst.warmup).
from mrhyst import warmup
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    out = warmup.warm(snakemake.wildcards.group)  # noqa: F821
    io.write_json(out, snakemake.output[0])  # noqa: F821
    print(f"warm-up {out['group']}: {', '.join(out['kernels'])}")
