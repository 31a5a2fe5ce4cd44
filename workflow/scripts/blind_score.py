# Snakemake script for rule blind_score: the only step that reads the key (mrhyst.blind.score). When the
# diagnosis has a pure selection policy (mrhyst.diagnose.policy.decide), the trade-off curve is replayed on the
# evidence blocks of the diagnoses (mrhyst.blind.tradeoff).
from mrhyst import blind
from mrhyst.blind.settings import blind_settings
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    cfg = blind_settings(snakemake.params.config["blind"])  # noqa: F821  (once, at the boundary)
    s = blind.score(list(snakemake.input.diag), snakemake.input.key, cfg, policy=blind.load_policy())  # noqa: F821
    io.write_json(s, snakemake.output[0])  # noqa: F821
    print({k: v for k, v in s["overall"].items()})
    print({k: v for k, v in s["open_world"].items()})
    print({k: v for k, v in s["compound"].items()})
