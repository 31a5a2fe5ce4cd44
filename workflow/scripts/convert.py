# Snakemake script for rule convert: Hall voltage -> B of one group's sensor (mrhyst.data.io.raw_to_loop, the same
# function as `mrhyst convert`).
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    loop = io.raw_to_loop(io.read_raw(sm.input.csv), sm.params.sensor)
    io.write_csv(loop, sm.output[0])
    print(f"{sm.input.csv} [{sm.params.sensor}] -> {sm.output[0]}: {len(loop)} samples")
