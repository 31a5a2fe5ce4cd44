# Shared set-up: config loading and validation, helpers for notebook rules.
import os
import shlex
import sys

from snakemake.utils import validate

from mrhyst.config import ConfigError, check_config
from mrhyst.snaketimers import one_reevaluation_timer


configfile: "config.yaml"


# one clear line for a bad config (unknown key, wrong type, lower > upper), then the schema's defaults
try:
    check_config(config, source="config.yaml")
except ConfigError as _e:
    sys.stderr.write(f"error: {_e}\n")
    sys.exit(2)
validate(config, "../mrhyst/schemas/config.schema.yaml")

GROUPS = sorted(config["groups"])


# Snakemake reruns a job when its params, input set, code or software change, but it does not see the config a
# script reads through snakemake.config. So every rule whose script reads the config names the sections it
# depends on as a param ("params" rerun trigger): editing config.yaml reruns exactly the jobs the edit concerns,
# and the next run after an edit is never stale. The PSO seed list and run_settings say which fits exist, not
# what one computes: adding a seed adds fits and changes none (the fit_pso job of each group and setting runs
# again, since it runs every seed, and writes the old seeds' same bytes).
_JOB_LIST_KEYS = {"pso": ("seeds", "run_settings")}


def config_of(*sections):
    """The named config sections (without the job-list keys) as one rule param."""
    out = {}
    for sec in sections:
        val = config.get(sec)
        if isinstance(val, dict):
            val = {k: v for k, v in val.items() if k not in _JOB_LIST_KEYS.get(sec, ())}
        out[sec] = val
    return out


# what mrhyst.fit.identify reads (identify.resolve_config): the fits, the profiles, the form comparison
STUDY_CONFIG = ("paper", "ja", "pso", "lsm", "identifiability", "metrics")
# Priority of the short jobs that start a chain ending in the report (the paper's convert -> fits -> tables, the
# aftercare and later benchmarks' generate -> diagnose -> figures; a diagnosis or score and its figure): above the
# long blocks (1), below the key's draws (9-10) and the warm-up (20). Left at 0 they ran last, one link at a time, and
# the build's last ~30 s kept one core idle for most of it (bench/README "Eleventh session"); the figures' own
# sources (diagnose, simulate_fig2, the scores, external_table, gdlaws_diagnose) still ran within the last 10 s and
# the report's notebook waited for their figures (bench/README "Twelfth session").
GATE_PRIORITY = 2
# The long jobs, longest first (so the build ends on short jobs, on both cores; a 30-s block started last ended two
# builds alone, bench/README "Twelfth session"): a blind block, or a benchmark's rest of at least half a block's
# cases (~30 s), 5; a real-cores half (~26 s) 4; an external fit (4-19 s) 3; the shorter long jobs (gdlaws_fit,
# external_diagnose, a small rest: 2-9 s) 1, below the gates. All below the key's draws and realcores_generate,
# which the blocks wait for.
BLOCK_PRIORITY = 5
REALCORES_PRIORITY = 4
EXTERNAL_FIT_PRIORITY = 3
# every final artefact; stage files append to it (rule all collects it)
ALL_TARGETS = []


def raw_csv(group):
    return config["groups"][group]["raw"] + ".csv"


def raw_json(group):
    return config["groups"][group]["raw"] + ".json"


# The interpreter running Snakemake (its venv) runs every job, so rules work without an activated venv. It is
# named through an environment variable, not pasted into the command text: Snakemake reruns a shell rule whose
# text changed ("code" trigger), and `snakemake` (shebang .venv/bin/python3) and `python -m snakemake`
# (.venv/bin/python) would otherwise each rebuild everything the other built.
os.environ["MRHYST_PYTHON"] = sys.executable
PY = '"$MRHYST_PYTHON"'
# One BLAS thread per job (as the `mrhyst` console script, mrhyst.startup), unless the user set it: the flexible
# base's Gram products (everett.solve, 53-256 x 270 x 270) are above OpenBLAS's threading threshold, and two jobs on
# two cores would each start a second, spinning thread. The same bytes with one thread or more.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


# papermill from a shell rule with an explicit kernel (ARCHITECTURE 5), the kernel stopped at once after the last cell
# and the volatile metadata stripped so that a rebuild gives the same bytes, in one process (mrhyst.report.nbrun,
# which says why: the CLI's graceful kernel shutdown held a job ~3.3 s for nothing in ~1 of 10 runs, and two kernels
# starting at once could race for a TCP port; here each listens on Unix sockets of its own).
# {params.nbparams} is a string of "-p name value" pairs.
PAPERMILL = PY + " -m mrhyst.report.nbrun {input.nb} {output.nb} {params.nbparams} > {log} 2>&1"


def nbparams(**kw):
    """'-p name value' pairs for papermill, values quoted for the shell."""
    return " ".join(f"-p {k} {shlex.quote(str(v))}" for k, v in kw.items())


# Snakemake's job-rate limiter re-arms a 1-s re-evaluation timer after every scheduler pass, one more chain per job
# finished: ~4,500 passes and 19 s of the main process's CPU in a fresh build. One pending timer instead
# (mrhyst.snaketimers, which says why and what was measured).
onstart:
    one_reevaluation_timer(getattr(workflow, "scheduler", None))
