# Snakemake script for rule simulate_fig2.
from mrhyst import io, simulate
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    n_over_le = io.read_json(snakemake.input.nle)["n_over_le"]  # noqa: F821
    df = simulate.fig2_loop(snakemake.params.config, n_over_le)  # noqa: F821
    io.write_csv(df, snakemake.output[0])  # noqa: F821
