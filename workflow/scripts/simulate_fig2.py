# Snakemake script for rule simulate_fig2.
from mrhyst.data import io
from mrhyst.logs import to_log
from mrhyst.paper import fig2 as simulate

with to_log(snakemake.log[0]):  # noqa: F821
    n_over_le = io.read_json(snakemake.input.nle)["n_over_le"]  # noqa: F821
    df = simulate.fig2_loop(snakemake.params.config, n_over_le)  # noqa: F821
    io.write_csv(df, snakemake.output[0])  # noqa: F821
