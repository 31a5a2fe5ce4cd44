# Snakemake script for rule realcores_score: the only reader of the real-core key (mrhyst.blind.realscore).
import pandas as pd
from mrhyst.blind import realscore
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    s = realscore.score(list(sm.input.diag), sm.input.key, float(sm.params.config["realcores"]["size_tol"]))
    io.write_json(s, sm.output.score)
    io.write_csv(pd.DataFrame(s["rows"]), sm.output.table)
    print(s["overall"])
