# Snakemake script for rule infer_nle: the package computes, this only wires files.
from mrhyst.data import io
from mrhyst.logs import to_log
from mrhyst.paper import nle

with to_log(snakemake.log[0]):  # noqa: F821
    result = nle.infer_n_over_le(snakemake.params.config)  # noqa: F821
    print(result)
    io.write_json(result, snakemake.output[0])  # noqa: F821
